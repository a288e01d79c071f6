"""The runner's progress in a log: plain lines through a pipe, the live bar on a terminal
(issue 19, item 6)."""

from __future__ import annotations

import io
import os
import sys

from conftest import InlineExecutor

from demcal.campaign.config import load_campaign
from demcal.campaign.runner import RunLog, run_campaign


def _run_into(stream, campaign) -> None:
    old, sys.stderr = sys.stderr, stream
    try:
        run_campaign(campaign, progress=True, executor=InlineExecutor())
    finally:
        sys.stderr = old


def test_progress_through_a_pipe_is_plain_lines_at_a_modest_rate(campaign_file):
    campaign = load_campaign(campaign_file(sleep=0.0))
    read, write = os.pipe()
    with os.fdopen(read, "r", encoding="utf-8") as reader:
        with os.fdopen(write, "w", encoding="utf-8") as writer:  # 29 runs: far less than a pipe holds
            _run_into(writer, campaign)
        text = reader.read()
    assert text and "\r" not in text and "\x1b" not in text
    lines = text.splitlines()
    assert text.endswith("\n") and all(line.strip() for line in lines)
    assert lines[0] == "test campaign design: 29 runs, 0 of them finished before"
    assert lines[-1].startswith("test campaign design: 29/29 runs (100 %), failed 0, remaining 0, ")
    assert 6 <= len(lines) <= 12  # about one a tenth of the runs, not one an update


def test_a_terminal_keeps_the_live_bar(campaign_file):
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    stream = Terminal()
    _run_into(stream, load_campaign(campaign_file(sleep=0.0)))
    assert "\r" in stream.getvalue() and "29/29" in stream.getvalue()


def test_a_run_log_writes_a_line_a_tenth_and_after_a_quiet_minute():
    now = [0.0]
    out = io.StringIO()
    log = RunLog(200, 20, "design", out, clock=lambda: now[0])
    for _ in range(180):
        now[0] += 0.5
        log.set_postfix_str("failed=0 remaining=1")
        log.update(1)
    lines = out.getvalue().splitlines()
    assert len(lines) == 1 + 9  # the start, then 20 -> 200 runs crosses nine tenths
    assert lines[1] == "design: 40/200 runs (20 %), failed 0, remaining 1, 00:10 elapsed, ETA 01:20"
    log = RunLog(200, 0, "design", out, clock=lambda: now[0])
    before = len(out.getvalue().splitlines())
    now[0] += 61.0
    log.update(1)  # the same tenth, but a minute since the last line
    log.update(0)  # nothing finished: nothing to say
    assert len(out.getvalue().splitlines()) == before + 1
