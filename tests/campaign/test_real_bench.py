"""A real virtual experiment through the campaign machinery (slow: minutes).

Issue 5, acceptance 2 with the built-in engine: a small repose-funnel campaign at the
tiny profile runs through the local pool and through a Dask ``LocalCluster`` and gives
bit-identical responses for identical seeds.
"""

from __future__ import annotations

import pytest

from demcal.campaign.config import parse_campaign
from demcal.campaign.runner import design_results, run_campaign

REAL = """\
[campaign]
name = "real tiny"

[experiment]
test = "repose-funnel"
profile = "tiny"

[[factors]]
name = "B"
parameter = "particle.static_friction"
low = 0.3
high = 0.5

[[factors]]
name = "C"
parameter = "particle.rolling_friction"
low = 0.1
high = 0.3

[design]
type = "full-factorial"

[[conditions]]
name = "dry"
targets = { repose_angle_deg = { mean = 31.07, sd = 2.1 } }
"""


@pytest.mark.slow
def test_real_tiny_campaign_local_pool_equals_dask(tmp_path):
    pytest.importorskip("distributed")
    from demcal.bench.registry import names
    from demcal.campaign.executors import DaskExecutor

    if "repose-funnel" not in names():
        pytest.fail("the repose-funnel virtual test is not registered")
    path = tmp_path / "real.toml"
    path.write_text(REAL)
    campaign = parse_campaign(REAL, path)
    local = campaign.with_workdir(tmp_path / "local")
    dask = campaign.with_workdir(tmp_path / "dask")
    assert run_campaign(local, workers=2, progress=False).done == 4
    executor = DaskExecutor(None, workers=2)
    try:
        assert run_campaign(dask, progress=False, executor=executor).done == 4
    finally:
        executor.close()
    a, b = design_results(local), design_results(dask)
    assert list(a["key"]) == list(b["key"])
    assert list(a["status"]) == list(b["status"]) == ["done"] * 4
    assert list(a["repose_angle_deg"]) == list(b["repose_angle_deg"])
    folder = local.workdir / "runs" / a["artifacts_dir"][0]
    assert (folder / "run.json").is_file() and (folder / "result.json").is_file()
