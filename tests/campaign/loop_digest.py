"""A pytest plugin that records what every calibration loop of a test run decided.

Run loop tests with it to compare the loop's decisions before and after a change of
its code (the digest of :func:`loop_replay.loop_digest`, floats kept exactly)::

    DEMCAL_LOOP_DIGEST=before.json pytest -p loop_digest tests/campaign/test_loop.py
    (change the loop)
    DEMCAL_LOOP_DIGEST=after.json pytest -p loop_digest tests/campaign/test_loop.py
    python tests/campaign/loop_digest.py before.json after.json

Each test's loops are listed in the order they ran, with the arguments of every ``run``
call they made; the tests' temporary folders are written ``<dir>``. Beside the digest,
``<name>.transitions.json`` lists the state transitions each test's loops took.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

_current = {"test": None}
_found: dict[str, list] = {}
_walked: dict[str, list] = {}  #: test -> the (state, next state) pairs its loops took


def pytest_configure(config):
    out = os.environ.get("DEMCAL_LOOP_DIGEST")
    if not out:
        return
    from demcal.campaign import loop

    from loop_replay import loop_digest, plain

    real = loop.run_condition

    def recorded(*args, run, **kw):
        asked = []

        def run_recorded(specs, desc):
            asked.append([desc, [s.key for s in specs]])
            return run(specs, desc)

        result = real(*args, run=run_recorded, **kw)
        base = config._tmp_path_factory.getbasetemp() if hasattr(config, "_tmp_path_factory") else None
        _found.setdefault(_current["test"], []).append(plain({**loop_digest(result), "asked": asked}, base))
        _walked.setdefault(_current["test"], []).extend(getattr(result, "transitions", []))
        return result

    loop.run_condition = recorded


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _current["test"] = item.nodeid
    yield


def pytest_unconfigure(config):
    out = os.environ.get("DEMCAL_LOOP_DIGEST")
    if out:
        Path(out).write_text(json.dumps(_found, indent=1, sort_keys=True) + "\n")
        walked = {test: sorted(set(map(tuple, pairs))) for test, pairs in _walked.items() if pairs}
        Path(out).with_suffix(".transitions.json").write_text(json.dumps(walked, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    before, after = (json.loads(Path(p).read_text()) for p in sys.argv[1:3])
    differ = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    for k in differ:
        print("differs:", k)
    print(f"{len(before)} tests before, {len(after)} after, {len(differ)} differ")
    sys.exit(1 if differ else 0)
