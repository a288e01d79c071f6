"""``--goal RESP=KIND[:numbers][:key=value...]``: every documented form is read, and a
typo, an unknown key or a wrong count of numbers is one sentence, never ignored."""

import pytest

from demcal.cli import main
from demcal.errors import ConfigError
from demcal.optimize import parse_goal


@pytest.mark.parametrize("spec, expected", [
    ("beta=target:31.07", dict(kind="target", target=31.07, low=None, high=None, importance=3)),
    ("y=max", dict(kind="maximize", low=None, high=None)),
    ("y=min", dict(kind="minimize")),
    ("y=maximise", dict(kind="maximize")),
    ("y=range", dict(kind="in_range", low=None, high=None)),
    ("y=in-range", dict(kind="in_range")),
    ("y=range:10:20", dict(kind="in_range", low=10.0, high=20.0)),
    ("y=range:low=10:high=20", dict(kind="in_range", low=10.0, high=20.0)),
    ("y=target:31.07:low=30:high=33:importance=5:weight=2",
     dict(target=31.07, low=30.0, high=33.0, importance=5, weight_low=2.0, weight_high=2.0)),
    ("y=target:31:weight_low=0.5:weight_high=3", dict(weight_low=0.5, weight_high=3.0)),
    ("y=max:low=1:importance=1:weight=4", dict(kind="maximize", low=1.0, importance=1, weight_low=4.0)),
    (" y = target : 31 : Importance = 2 ", dict(response="y", target=31.0, importance=2)),
    ("y=TARGET:31", dict(kind="target", target=31.0)),
    ("y=target:-2.5e1", dict(target=-25.0)),
])
def test_documented_goals_are_read(spec, expected):
    g = parse_goal(spec)
    for key, value in expected.items():
        assert getattr(g, key) == value, (spec, key, getattr(g, key))


@pytest.mark.parametrize("spec, words", [
    ("y=target:31:imprtance=5", ["'imprtance'", "importance", "low, high"]),
    ("y=max:wieght=2", ["'wieght'", "weight"]),
    ("y=range:20", ["y=range:20", "two numbers", "y=range:LOW:HIGH"]),
    ("y=range:10:20:30", ["three numbers", "y=range:LOW:HIGH"]),
    ("y=target:31:32", ["two numbers", "y=target:T"]),
    ("y=target", ["y=target:T"]),
    ("y=max:10", ["y=max", "low="]),
    ("y=min:1:2", ["y=min", "low="]),
    ("y=range:10:20:low=5", ["low"]),
    ("y=target:31:importance=2.5", ["importance", "whole number"]),
    ("y=target:31:importance=3:importance=5", ["importance", "twice"]),
    ("y=target:nan", ["nan"]),
    ("y=max:low=inf", ["inf"]),
    ("y=target:31:weight=0", ["weight", "0.1"]),
    ("y=:", ["y=max"]),
    ("y= ", ["y=max"]),
    (" =max", ["response"]),
    ("y=sideways", ["sideways"]),
    ("y=target:x", ["'x'"]),
    ("y=target:31:importance", ["importance"]),
    # keys that the goal kind would ignore
    ("y=range:10:20:weight=2", ["'weight'", "range", "low, high and importance"]),
    ("y=max:weight_high=2", ["'weight_high'", "target"]),
])
def test_goal_typos_are_refused(spec, words):
    with pytest.raises(ConfigError) as info:
        parse_goal(spec)
    message = str(info.value)
    assert "\n" not in message and message.endswith("."), message
    for word in words:
        assert word in message, (spec, word, message)


def test_cli_goal_typo_is_one_sentence(tmp_path, capsys):
    runs = tmp_path / "runs.csv"
    runs.write_text("a,b,y\n-1,-1,1\n1,-1,2\n-1,1,3\n1,1,4\n0,0,2.5\n")
    rc = main(["optimize", str(runs), "--goal", "y=target:3:imprtance=5", "--model", "linear"])
    err = capsys.readouterr().err
    assert rc == 2 and err.startswith("demcal: error: ") and err.count("\n") == 1, err
    assert "'imprtance'" in err and "Traceback" not in err
