"""A real virtual experiment through the campaign machinery (about 10 s).

Issue 5, acceptance 2 with the built-in engine: a small repose-funnel campaign at the
tiny profile runs through the local pool and through a Dask ``LocalCluster`` and gives
bit-identical responses for identical seeds.
"""

from __future__ import annotations

import pytest

from demcal.campaign.config import parse_campaign

from conftest import factor_tables, local_and_dask_results

REAL = """\
[campaign]
name = "real tiny"

[experiment]
test = "repose-funnel"
profile = "tiny"

""" + factor_tables("BC") + """\
[design]
type = "full-factorial"

[[conditions]]
name = "dry"
targets = { repose_angle_deg = { mean = 31.07, sd = 2.1 } }
"""


def test_real_tiny_campaign_local_pool_equals_dask(tmp_path):
    pytest.importorskip("distributed")
    from demcal.bench.registry import names

    assert "repose-funnel" in names()
    path = tmp_path / "real.toml"
    path.write_text(REAL)
    a, b = local_and_dask_results(parse_campaign(REAL, path), tmp_path)
    assert list(a["status"]) == list(b["status"]) == ["done"] * 4
    assert list(a["key"]) == list(b["key"])
    assert list(a["repose_angle_deg"]) == list(b["repose_angle_deg"])
    folder = tmp_path / "local" / "runs" / a["artifacts_dir"][0]
    assert (folder / "run.json").is_file() and (folder / "result.json").is_file()
