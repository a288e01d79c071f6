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
    assert len(COMMAND_MODULES) == 6
    assert {"design", "analyze", "optimize", "measure", "bench", "run", "calibrate", "report",
            "demo"} <= set(sub.choices)
    assert all(callable(p.get_default("func")) for p in sub.choices.values())
