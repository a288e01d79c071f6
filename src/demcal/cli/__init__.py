"""The ``demcal`` command line: the one layer above every subsystem.

Each module of this package (``demcal.cli.doe``, ``demcal.cli.rsm``, ...) holds the
sub-commands of one subsystem: a module listed in :data:`COMMAND_MODULES` exposes
``register(subparsers)``, which adds its parsers and sets ``func`` on each
(``func(args) -> int`` exit status). The subsystems never import this package; it
imports them, inside the functions that run a command. Errors of type
:class:`demcal.errors.DemcalError` are printed as one sentence, exit status 2; so
are file-system errors (:class:`OSError`: a file where a folder is wanted, no
permission, a full disk), which name the path and what to do.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import signal
import sys
import threading
from pathlib import Path

from demcal import __version__
from demcal.errors import ConfigError, DemcalError

#: Modules that contribute sub-commands, in the order they appear in ``--help``.
COMMAND_MODULES = (
    "demcal.cli.doe",  # design
    "demcal.cli.rsm",  # analyze
    "demcal.cli.optimize",  # optimize
    "demcal.cli.measure",  # measure repose|incline
    "demcal.cli.bench",  # bench NAME
    "demcal.cli.campaign",  # run, calibrate, report, demo
    "demcal.cli.identify",  # identify
    "demcal.cli.export",  # export
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="demcal",
        description="Calibrate DEM contact parameters of granular materials from bench tests.",
    )
    parser.add_argument("--version", action="version", version=f"demcal {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:  # a subsystem not built yet
            if exc.name and name.startswith(exc.name):
                continue
            raise
        module.register(subparsers)
    return parser


#: The last line after the help when no command is given.
NO_COMMAND = "give a command, e.g. demcal demo or demcal run CAMPAIGN.toml; see demcal --help."


def main(argv: list[str] | None = None) -> int:
    """Run one ``demcal`` command; return its exit status.

    0 done; 2 a user's mistake (one sentence: a bad file, option or value, no command
    at all); 70 a bug in demcal. Ctrl-C, SIGTERM (``kill``, ``timeout``, systemd, Slurm
    at a job's time limit or ``scancel``) and SIGHUP (a closed terminal) stop every
    command alike: the signal raises ``KeyboardInterrupt`` wherever the command is, its
    clean-up runs (a runner stops its workers, hands its claims back and removes its
    temporary folders, holding back any further signal until that is done), and one
    sentence says that finished results are kept. The exit status is then 128 + the
    signal's number, the shell's code for a process that signal stopped: 130 for Ctrl-C,
    143 for SIGTERM, 129 for SIGHUP. A job script can thus tell a time-out or a
    cancelled job (143) from a user's Ctrl-C (130), and ``timeout --preserve-status``
    or a batch system reports what it reports for any program that SIGTERM stopped. A
    signal that was ignored when demcal started (``nohup`` ignores SIGHUP) stays ignored.
    """
    replaced = _catch_stop_signals()
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            print(f"demcal: error: {NO_COMMAND}", file=sys.stderr)
            return 2
        _check_out_folder(getattr(args, "out", None))
        _check_seed_and_workers(args)
        return int(args.func(args) or 0)
    except DemcalError as exc:
        print(f"demcal: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError as exc:
        if _stdout_closed():
            return _quiet_broken_pipe()
        print(f"demcal: error: {os_error_sentence(exc)}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"demcal: error: {os_error_sentence(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        how = "" if signum == signal.SIGINT else f" ({signal.Signals(signum).name})"
        print(f"demcal: interrupted{how}; finished results are kept.", file=sys.stderr)
        return 128 + signum
    except Exception as exc:  # a bug in demcal, not the user's input
        if os.environ.get("DEMCAL_DEBUG"):
            raise
        return _internal_error(exc)
    finally:
        for signum, handler in replaced.items():
            signal.signal(signum, handler)


class SignalInterrupt(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where Ctrl-C raises ``KeyboardInterrupt``: every
    clean-up that catches an interrupt catches these too."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)


def _raise_interrupt(signum: int, _frame) -> None:
    raise SignalInterrupt(signum)


def _catch_stop_signals() -> dict[int, object]:
    """Make SIGTERM and SIGHUP stop a command as Ctrl-C does; return the handlers replaced.

    Only from the main thread, and only signals left at their default action: one that
    is ignored (``nohup``) or that a host program handles stays as it is.
    """
    if threading.current_thread() is not threading.main_thread():
        return {}
    replaced = {}
    for signum in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(signum) == signal.SIG_DFL:
            replaced[signum] = signal.signal(signum, _raise_interrupt)
    return replaced


#: Exit status of a command that stopped on a bug in demcal (BSD's EX_SOFTWARE).
INTERNAL_ERROR_STATUS = 70


def _internal_error(exc: BaseException) -> int:
    """One sentence for a bug in demcal; the traceback goes to a file, not the screen."""
    import tempfile
    import traceback

    where = ""
    try:
        fd, path = tempfile.mkstemp(prefix="demcal-traceback-", suffix=".txt")
        with os.fdopen(fd, "w") as f:
            f.write("".join(traceback.format_exception(exc)))
        where = f" (the traceback is in {path})"
    except OSError:
        pass
    print(f"demcal: internal error: {type(exc).__name__}: {exc}; this is a bug in demcal, not in "
          f"your input{where}: please report it with the command you ran. Finished results are kept; "
          "set DEMCAL_DEBUG=1 to see the traceback here.", file=sys.stderr)
    return INTERNAL_ERROR_STATUS


#: Exit status of a command whose reader went away (`demcal ... | head`), as if killed by SIGPIPE.
BROKEN_PIPE_STATUS = 128 + 13


def _stdout_closed() -> bool:
    """Whether standard output is a pipe nobody reads any more."""
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        return True
    except (OSError, ValueError):
        return False
    try:  # the failed write left nothing buffered: ask the pipe itself
        import select

        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(events & select.POLLERR for _, events in poll.poll(0))
    except (AttributeError, OSError, ValueError):  # pragma: no cover - no poll, no descriptor
        return False


def _quiet_broken_pipe() -> int:
    """Stop without a word: point stdout at /dev/null so the flush at exit cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # pragma: no cover - no file descriptor behind stdout
        pass
    return BROKEN_PIPE_STATUS


def _check_seed_and_workers(args) -> None:
    """The same rule for every command: ``--seed`` in 0 .. 2^63 - 1, ``--workers`` 1 or
    more or 0 for one per core."""
    from demcal._checks import check_seed, check_workers

    if getattr(args, "seed", None) is not None:
        check_seed(args.seed, "--seed")
    if getattr(args, "workers", None) is not None:
        check_workers(args.workers, "--workers")


def _check_out_folder(out) -> None:
    """Every command's ``--out`` is a folder (created if missing): refuse a path that is,
    or lies below, an existing file before any work is done."""
    if out is None or str(out) == "":
        return
    path = Path(out)
    blocker = _file_in_the_way(path)
    if blocker is None:
        return
    if blocker == path:
        raise ConfigError(f"--out {path} is a file, not a folder; give --out a folder path "
                          "(it is created if missing).")
    raise ConfigError(f"--out {path} cannot be created: {blocker} is a file, not a folder; "
                      "give --out a folder path.")


def _file_in_the_way(path: Path) -> Path | None:
    """``path`` or the first of its parents that exists but is not a folder, if any."""
    for candidate in [*reversed(path.parents), path]:
        try:
            if candidate.exists() and not candidate.is_dir():
                return candidate
        except OSError:
            return None
    return None


def os_error_sentence(exc: OSError) -> str:
    """One sentence naming the path and the problem of a file-system error."""
    name = exc.filename if exc.filename is not None else exc.filename2
    reason = (exc.strerror or str(exc) or type(exc).__name__).rstrip(".")
    if name is None:
        return f"file-system error: {reason[:1].lower() + reason[1:]}."
    path = Path(os.fsdecode(name))
    code = exc.errno
    if isinstance(exc, NotADirectoryError) or code == errno.ENOTDIR:
        blocker = _file_in_the_way(path)
        if blocker == path:
            return f"cannot use {path}: it is a file, not a folder; give a folder path."
        where = f"{blocker} is a file" if blocker is not None else "part of that path is a file"
        return f"cannot write to {path}: {where}, not a folder; give a folder path or move that file."
    if isinstance(exc, FileExistsError) or code == errno.EEXIST:
        what = " as a file" if path.exists() and not path.is_dir() else ""
        return f"cannot create {path}: it already exists{what}; give another path or move it away."
    if isinstance(exc, IsADirectoryError) or code == errno.EISDIR:
        return f"{path} is a folder, not a file; give a file path."
    if isinstance(exc, PermissionError) or code in (errno.EACCES, errno.EPERM, errno.EROFS):
        return (f"permission denied for {path}; choose a place you can write to "
                "or change the permissions.")
    if isinstance(exc, FileNotFoundError) or code == errno.ENOENT:
        return f"{path} does not exist; check the path."
    if code in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)):
        return f"no space left on the disk that holds {path}; free some space and run again."
    return f"cannot access {path}: {reason[:1].lower() + reason[1:]}."


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
