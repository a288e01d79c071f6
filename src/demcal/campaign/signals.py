"""Holding Ctrl-C, SIGTERM and SIGHUP back while a short critical section runs."""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Any, Iterator

#: The signals that stop a command: Ctrl-C, ``kill`` (``timeout``, Slurm, systemd), a closed terminal.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@contextlib.contextmanager
def held_signals() -> Iterator[None]:
    """Hold Ctrl-C, SIGTERM and SIGHUP back while a short critical section runs.

    A signal that arrives inside the block is noted instead of acted on; at its end
    the handlers in place before are restored and each noted signal is raised again,
    once, so the command then stops as it would have (``KeyboardInterrupt``, or the
    signal's default action where nothing handles it). The runner's clean-up and the
    store's commit of a run use it: a second signal during the clean-up of the first
    cannot stop the hand-back of a claim half way and leave its row ``running`` or
    its temporary folder behind. Only the main thread may change handlers (elsewhere
    the block runs unguarded); an ignored signal (``nohup``) or one handled outside
    Python is left alone. Blocks nest.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []
    previous: dict[int, Any] = {}
    try:
        for signum in STOP_SIGNALS:
            handler = signal.getsignal(signum)
            if handler is None or handler == signal.SIG_IGN:
                continue
            previous[signum] = handler
            signal.signal(signum, lambda number, _frame: noted.append(number))
        yield
    finally:
        stop = None
        for signum, handler in previous.items():
            while True:  # a signal arriving between two restores: restore the others before it acts
                try:
                    signal.signal(signum, handler)
                    break
                except BaseException as exc:  # noqa: BLE001 - raised once every handler is back
                    stop = stop or exc
        for signum in dict.fromkeys(noted):
            signal.raise_signal(signum)
        if stop is not None:
            raise stop
