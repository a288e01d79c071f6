"""The `demcal` command line starts without the numerical libraries."""

import subprocess
import sys

from demcal.cli import COMMAND_MODULES, build_parser

HEAVY = ("numpy", "scipy", "pandas", "matplotlib", "skimage", "numba", "dask", "PIL")


def test_help_imports_no_numerical_library():
    code = ("import sys; from demcal.cli import build_parser; build_parser(); "
            f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_every_command_module_registers_its_commands():
    sub = build_parser()._subparsers._group_actions[0]
    assert len(COMMAND_MODULES) == 8
    assert {"design", "analyze", "optimize", "measure", "bench", "run", "calibrate", "report",
            "demo", "export", "identify"} <= set(sub.choices)
    assert all(callable(p.get_default("func")) for p in sub.choices.values())


# --------------------------------------------------------------------------- file-system mistakes
# A file where a folder is wanted (and the like) is one sentence with exit status 2,
# never a traceback.

import errno  # noqa: E402

import pytest  # noqa: E402

from demcal.cli import main  # noqa: E402


def _one_sentence(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("demcal: error: ")
    return err


@pytest.mark.parametrize("argv", [
    ["report", "repose.toml", "--out", "lab.toml"],
    ["bench", "repose-funnel", "--profile", "tiny", "--out", "lab.toml"],
    ["demo", "--out", "lab.toml"],
])
def test_out_that_is_a_file_is_one_sentence(example, capsys, argv):
    assert main(argv) == 2
    err = _one_sentence(capsys)
    assert "--out lab.toml is a file, not a folder" in err and "give --out a folder" in err


def test_out_below_a_file_is_one_sentence(example, capsys):
    assert main(["demo", "--out", "lab.toml/demo"]) == 2
    err = _one_sentence(capsys)
    assert "lab.toml is a file, not a folder" in err


def test_workdir_that_is_a_file_is_one_sentence(example, capsys):
    text = (example / "repose.toml").read_text()
    (example / "repose.toml").write_text(text.replace("[campaign]\n", '[campaign]\nworkdir = "lab.toml"\n', 1))
    assert main(["run", "repose.toml", "--profile", "tiny", "--quiet", "--workers", "1"]) == 2
    err = _one_sentence(capsys)
    assert "cannot write to lab.toml" in err and "lab.toml is a file, not a folder" in err


@pytest.mark.parametrize("exc, words", [
    (PermissionError(errno.EACCES, "Permission denied", "out/report.html"),
     "permission denied for out/report.html"),
    (OSError(errno.ENOSPC, "No space left on device", "out/store.sqlite"),
     "no space left on the disk that holds out/store.sqlite"),
    (IsADirectoryError(errno.EISDIR, "Is a directory", "out/report.html"),
     "out/report.html is a folder, not a file"),
    (FileExistsError(errno.EEXIST, "File exists", "out"), "cannot create out: it already exists"),
    (OSError(errno.EIO, "Input/output error", "out/x.csv"), "cannot access out/x.csv: input/output error"),
    (OSError("something broke"), "file-system error: something broke"),
])
def test_any_file_system_error_is_one_sentence(capsys, monkeypatch, exc, words):
    def fail(args):
        raise exc

    monkeypatch.setattr("demcal.cli.campaign._demo", fail)
    assert main(["demo"]) == 2
    err = _one_sentence(capsys)
    assert words in err, err


def test_keyboard_interrupt_is_still_its_own_message(capsys, monkeypatch):
    def stop(args):
        raise KeyboardInterrupt

    monkeypatch.setattr("demcal.cli.campaign._demo", stop)
    assert main(["demo"]) == 130
    assert "interrupted" in capsys.readouterr().err


# --------------------------------------------------------------------------- a closed pipe
# `demcal ... | head -2`: the reader went away; stop quietly, as other command-line tools do.

def test_closed_stdout_pipe_is_quiet():
    import os

    read, write = os.pipe()
    os.close(read)  # the reader is gone before demcal writes anything
    try:
        out = subprocess.run([sys.executable, "-m", "demcal", "design", "factorial", "-k", "3"],
                             stdout=write, stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write)
    assert out.stderr == "", out.stderr
    assert out.returncode in (0, 141)


# --------------------------------------------------------------------------- campaign help

def _help(command: str) -> str:
    import re

    sub = build_parser()._subparsers._group_actions[0]
    return re.sub(r"\s+", " ", sub.choices[command].format_help())


@pytest.mark.parametrize("command", ["run", "calibrate", "report"])
def test_profile_help_names_the_choices_and_the_default(command):
    text = _help(command)
    assert "tiny, quick, paper or a test's own (the incline's medium)" in text
    assert "default: the campaign file's [experiment] profile" in text


@pytest.mark.parametrize("command", ["run", "calibrate"])
def test_scheduler_help_says_what_a_cluster_needs(command):
    text = _help(command)
    assert "shared file system" in text and "same path" in text
    assert "--workers is ignored" in text


def test_a_bug_in_demcal_is_one_sentence_and_a_traceback_file(monkeypatch, capsys):
    """Never a raw traceback: an unexpected exception (a bug, not the user's input) is one
    sentence naming the file the traceback went to, exit status 70 (EX_SOFTWARE)."""
    import re
    from pathlib import Path

    import demcal.cli as cli

    def broken(args):
        raise RuntimeError("boom")

    monkeypatch.setattr(cli, "_check_seed_and_workers", broken)
    monkeypatch.delenv("DEMCAL_DEBUG", raising=False)
    assert cli.main(["bench", "--list"]) == cli.INTERNAL_ERROR_STATUS == 70
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert err.startswith("demcal: internal error: RuntimeError: boom; this is a bug in demcal")
    path = Path(re.search(r"the traceback is in (\S+)\)", err).group(1))
    assert "RuntimeError: boom" in path.read_text() and "Traceback" in path.read_text()
    path.unlink()
    monkeypatch.setenv("DEMCAL_DEBUG", "1")
    with pytest.raises(RuntimeError, match="boom"):
        cli.main(["bench", "--list"])
