

def test_a_factor_named_f_keeps_its_name_in_a_design_table():
    import pandas as pd

    from demcal.rsm.tables import display_table

    design = pd.DataFrame({"E": [-1], "F": [1], "G": [0], "published": [25.0]})
    assert list(display_table(design).columns) == ["E", "F", "G", "published"]
    anova = pd.DataFrame({"sum_sq": [1.0], "df": [1], "F": [3.0], "p": [0.1]})
    assert list(display_table(anova).columns) == ["Sum of Squares", "df", "F-value", "p-value"]
