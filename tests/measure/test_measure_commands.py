"""`demcal measure` command line."""

import json

import pytest
from skimage import io

from demcal.cli import main
from demcal.measure.synthetic import synthetic_photo


def test_incline_json(capsys):
    assert main(["measure", "incline", "--H", "150", "150", "--L", "300", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mean_deg"] == pytest.approx(30.0)


def test_incline_level_height(capsys):
    assert main(["measure", "incline", "--H", "170", "170", "--L", "300", "--H0", "20"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == ("sliding angle 30.00 +- 0.00 deg over 2 readings "
                                                        "(L = 300 mm, H0 = 20 mm)")
    assert main(["measure", "incline", "--H", "10", "--H0", "20"]) == 2
    err = capsys.readouterr().err
    assert "each H must lie between H0 and H0 + L (20 and 320 mm)" in err and err.count("\n") == 1


def test_incline_bad_reading_is_one_sentence(capsys):
    assert main(["measure", "incline", "--H", "400", "--L", "300"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("demcal: error: reading 1: H = 400.0 mm") and err.count("\n") == 1


def test_repose_batch_json_with_a_bad_photo(tmp_path, capsys):
    paths = []
    for i, a in enumerate([30.0, 32.0]):
        p = tmp_path / f"h{i}.png"
        io.imsave(p, synthetic_photo(a, seed=i).image)
        paths.append(str(p))
    (tmp_path / "x.png").write_text("nope")
    out_dir = tmp_path / "out"
    code = main(["measure", "repose", *paths, str(tmp_path / "x.png"), "--out", str(out_dir), "--json"])
    assert code == 0
    captured = capsys.readouterr()
    d = json.loads(captured.out)
    assert d["summary"]["n"] == 2 and d["summary"]["mean"] == pytest.approx(31.0, abs=0.5)
    assert d["summary"]["failed"] == [str(tmp_path / "x.png")]
    assert "cannot read photo" in captured.err
    assert (out_dir / "h0_fit.png").exists() and (out_dir / "table.csv").exists()


def test_repose_single_bad_photo_exits_2(tmp_path, capsys):
    assert main(["measure", "repose", str(tmp_path / "none.png")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_repose_bad_roi(tmp_path, capsys):
    p = tmp_path / "h.png"
    io.imsave(p, synthetic_photo(30.0).image)
    assert main(["measure", "repose", str(p), "--roi", "1,2,3"]) == 2
    assert "--roi must be 4" in capsys.readouterr().err
