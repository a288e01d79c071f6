"""ProgressReporter: prints in batch jobs (no terminal) and ends on the final state."""

import io

from demcal.dem.reporters import ProgressReporter


class _FakeSim:
    """What a reporter reads from a simulation."""

    def __init__(self):
        self.step_count = 0
        self.time = 0.0
        self.n_particles = 10

    def advance(self, steps, dt=1e-4):
        self.step_count += steps
        self.time = self.step_count * dt


def _run(reporter, total=3000, dt=1e-4):
    sim = _FakeSim()
    reporter.start(sim, total)
    while sim.step_count < total:
        k = min(reporter.next_report(sim), total - sim.step_count)
        sim.advance(k, dt)
        if sim.step_count % reporter.interval == 0:
            reporter.report(sim)
    reporter.finish(sim)
    return sim


def test_progress_prints_when_the_output_is_not_a_terminal():
    out = io.StringIO()
    assert not out.isatty()
    _run(ProgressReporter(interval=200, file=out))
    text = out.getvalue()
    assert "DEM" in text and "100%" in text


def test_progress_final_line_shows_the_final_time():
    out = io.StringIO()
    sim = _run(ProgressReporter(interval=200, file=out), total=2813 + 187, dt=1e-4)
    lines = [ln for ln in out.getvalue().replace("\r", "\n").split("\n") if ln.strip()]
    assert "100%" in lines[-1] and "t=0.3 s" in lines[-1], lines[-1]


def test_progress_stale_time_is_refreshed_on_close():
    # last report at 2800 steps, the run ends 13 steps later without a report
    out = io.StringIO()
    rep = ProgressReporter(interval=200, file=out)
    sim = _FakeSim()
    rep.start(sim, 2813)
    for _ in range(14):
        sim.advance(200)
        rep.report(sim)
    sim.advance(13)
    rep.finish(sim)
    last = [ln for ln in out.getvalue().replace("\r", "\n").split("\n") if ln.strip()][-1]
    assert "2813/2813" in last and f"t={sim.time:.4g} s" in last, last


def test_progress_in_a_log_is_one_line_per_update():
    out = io.StringIO()
    _run(ProgressReporter(interval=200, file=out))
    text = out.getvalue()
    assert "\r" not in text
    assert text.endswith("\n")


def test_progress_can_still_be_disabled():
    out = io.StringIO()
    _run(ProgressReporter(interval=200, file=out, disable=True))
    assert out.getvalue() == ""
