"""What ``demcal bench`` says while it runs: simulated time, share of the time limit,
ETA and speed; rewritten in place on a terminal, plain lines in a log."""

import io

from demcal.bench import common as C
from demcal.bench.experiment import Phase, Setup, run_phase
from demcal.bench.registry import get_experiment
from demcal.cli import main
from demcal.dem.reporters import StatusLine


class _Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class _Terminal(io.StringIO):
    def isatty(self):
        return True


class _Sim:
    """What the progress reads of a simulation; each step costs ``wall_per_step`` seconds
    of the fake clock. ``run`` is the engine's run control in small (``dem/control.py``):
    reporters asked when they next want data, reported to when due, ended by
    ``StopRun``."""

    def __init__(self, clock, dt=0.01, wall_per_step=0.1):
        self.clock, self.dt, self.wall_per_step = clock, dt, wall_per_step
        self.time, self.step_count, self.n_particles = 0.0, 0, 0

    def run(self, steps, reporters=()):
        from types import SimpleNamespace

        from demcal.dem.reporters import StopRun

        reporters = list(reporters)
        for r in reporters:
            if hasattr(r, "start"):
                r.start(self, steps)
        done, stopped = 0, None
        try:
            while done < steps:
                want = [max(1, int(r.next_report(self))) for r in reporters]
                n = min([steps - done] + want)
                self.step_count += n
                self.time = self.step_count * self.dt
                self.clock.now += n * self.wall_per_step
                done += n
                for r, k in zip(reporters, want):
                    if k == n:
                        r.report(self)
        except StopRun as stop:
            stopped = stop.reason
        finally:
            for r in reporters:
                r.finish(self) if hasattr(r, "finish") else None
        return SimpleNamespace(stopped=stopped)


def test_status_line_in_a_log_is_plain_lines_every_interval():
    out, clock = io.StringIO(), _Clock()
    line = StatusLine(out, log_interval=10.0, clock=clock)
    line.update("a")            # the first status only after one interval
    clock.now += 9.0
    line.update("b")
    assert out.getvalue() == ""
    clock.now += 1.0
    line.update("c")
    line.message("a message")
    clock.now += 5.0
    line.update("d")
    line.close()
    assert out.getvalue() == "c\na message\n"


def test_status_line_on_a_terminal_is_rewritten_in_place():
    out, clock = _Terminal(), _Clock()
    line = StatusLine(out, refresh=0.2, clock=clock)
    line.update("t = 1")
    clock.now += 0.125
    line.update("t = 2")        # too soon: not drawn
    clock.now += 0.125
    line.update("t = 3")
    line.message("settled")     # above the status, which is drawn again
    line.close()
    assert out.getvalue() == ("\rt = 1\x1b[K" "\rt = 3\x1b[K"
                              "\r\x1b[Ksettled\nt = 3\x1b[K" "\r\x1b[K")


def test_status_line_is_cut_to_the_terminal_width(monkeypatch):
    monkeypatch.setenv("COLUMNS", "20")
    out = _Terminal()
    StatusLine(out).update("x" * 50)
    assert out.getvalue() == "\r" + "x" * 16 + "...\x1b[K"


def test_a_phase_shows_time_share_of_the_limit_eta_and_pace():
    out, clock = io.StringIO(), _Clock()
    progress = C.Progress(True, file=out, log_interval=5.0, clock=clock)
    sim = _Sim(clock)
    with C.showing(progress):
        # 10 steps of 0.01 s per chunk, 1 s of wall time per chunk: 10 s per simulated s
        assert run_phase(Setup(sim, []), Phase(lambda: False, max_time=2.0, chunk=0.1)) == "time limit"
        sim.run(steps=10, reporters=[progress.reporter])   # after the limit: no share, no ETA
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue()
    assert lines[0] == ("  [   5.0 s] t = 0.500 s (25 % of the 2 s limit), ETA at most 15 s, "
                        "10 s per simulated s")
    assert lines[1] == ("  [  10.0 s] t = 1.000 s (50 % of the 2 s limit), ETA at most 10 s, "
                        "10 s per simulated s")
    assert lines[-1] == "  [  20.0 s] t = 2.000 s (100 % of the 2 s limit), ETA at most 0 s, 10 s per simulated s"
    assert len(lines) == 4
    clock.now += 5.0
    progress.update(sim)   # outside a phase: time and pace only
    assert out.getvalue().splitlines()[-1] == "  [  26.0 s] t = 2.100 s, 12.5 s per simulated s"


def test_eta_is_written_in_minutes_and_hours():
    assert [C._duration(s) for s in (0.4, 59.4, 185, 3600 + 125)] == ["0 s", "59 s", "3 min 05 s",
                                                                      "1 h 02 min"]


def test_a_bench_log_gets_status_lines_and_no_carriage_returns(capsys, monkeypatch):
    monkeypatch.setattr(C.Progress, "LOG_INTERVAL", 0.0)
    assert main(["bench", "impact", "--profile", "tiny"]) == 0
    err = capsys.readouterr().err
    assert "\r" not in err and "\x1b" not in err
    lines = err.splitlines()
    assert any(line.split("] ")[1].startswith("impact on particle: e = ") for line in lines)
    status = [line for line in lines if "] t = " in line]
    assert len(status) >= 10 and "s per simulated s" in status[-1]


def test_showing_progress_does_not_change_the_run():
    impact = get_experiment("impact")
    quiet = impact.run({"particle.damping_factor": 0.05}, profile="tiny", progress=False)
    shown = impact.run({"particle.damping_factor": 0.05}, profile="tiny", progress=True)
    assert shown.steps == quiet.steps
    assert shown.responses == quiet.responses  # bit for bit
    assert C._PROGRESS.get() is None


def test_json_output_has_no_progress(capsys):
    assert main(["bench", "impact", "--profile", "tiny", "--json"]) == 0
    assert capsys.readouterr().err == ""


def test_progress_off_writes_nothing():
    out = io.StringIO()
    progress = C.Progress(False, file=out)
    progress("hello")
    progress.close()
    assert out.getvalue() == ""
