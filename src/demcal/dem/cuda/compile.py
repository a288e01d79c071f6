"""The CPU kernels' own Python source, compiled a second time as CUDA device functions.

Every physics kernel of the engine (the contact sub-models of :mod:`demcal.dem.contact`,
the pair and wall drivers of :mod:`demcal.dem.forces`, the integrator, the wall
distances and placements of :mod:`demcal.geometry`, the neighbour-search rows) is a
numba ``@njit`` function of scalars and arrays over a range ``[lo, hi)``.
:func:`device_function` takes such a function's Python code object and compiles it with
``numba.cuda.jit(device=True)``, after pointing each global name it calls at the device
version of that callee (recursively), so the CUDA backend runs the very expressions the
CPU backend runs: there is no second copy of a contact law, and the two cannot drift.

One substitution is made, and it is exact: :func:`demcal.dem.contact.llvm_math.sqrt`
(an LLVM intrinsic for the CPU) becomes ``math.sqrt``, which numba-cuda lowers to
libdevice's correctly rounded ``__nv_sqrt``. ``chosen.normal`` etc. (the sub-model ids)
read a namedtuple of the same field names on the device (:class:`ChosenIds`), built by
each kernel from constants.

**Rounding as written.** The CPU engine compiles without fast-math licences, so every
multiply and add rounds on its own. NVVM, left to itself, fuses multiplies and adds
into FMAs (its ``-fma=1`` default), which rounds differently; numba-cuda has no switch
for it, so :func:`exact_arithmetic` passes ``fma=0`` to NVVM for every kernel compiled
without ``fastmath`` (a wrapper around ``numba.cuda.cudadrv.nvvm.compile_ir``, the one
place numba-cuda hands options to NVVM; ``DEMCAL_CUDA_FMA=1`` leaves NVVM's default).
Division and square root are IEEE in either case (``prec_div``, ``prec_sqrt``).
What can still differ from the CPU is the last bit of a transcendental function
(libdevice's ``sin``, ``cos``, ``pow`` against the C library's).

The device functions are made once per process and CPU function.
"""

from __future__ import annotations

import math
import os
import types
from collections import namedtuple

from numba.core.registry import CPUDispatcher

from ..contact import llvm_math

#: The sub-model ids on the device, read by the drivers as ``chosen.normal`` etc.
ChosenIds = namedtuple("ChosenIds", ["normal", "damping", "tangential", "rolling"])

_DEVICE: dict = {}


def _cuda():
    from numba import cuda
    return cuda


def exact_arithmetic() -> bool:
    """Make NVVM round every multiply and add on its own (no FMA contraction) in kernels
    compiled without ``fastmath``; returns whether it is in force (see the module
    docstring)."""
    if os.environ.get("DEMCAL_CUDA_FMA") == "1":
        return False
    try:
        from numba.cuda.cudadrv import nvvm
    except ImportError:
        return False
    if getattr(nvvm.compile_ir, "demcal_no_fma", False):
        return True
    inner = nvvm.compile_ir

    def compile_ir(llvmir, **options):
        if not options.get("fastmath"):
            options.setdefault("fma", False)
        return inner(llvmir, **options)

    compile_ir.demcal_no_fma = True
    nvvm.compile_ir = compile_ir
    return True


def python_function(fn):
    """The Python function behind a numba dispatcher (or ``fn`` itself)."""
    return fn.py_func if isinstance(fn, CPUDispatcher) else fn


def device_function(fn):
    """``fn`` (an ``@njit`` kernel) compiled from its own code object as a CUDA device
    function, with each ``@njit`` callee it names replaced by that callee's device
    function and the CPU square-root intrinsic by ``math.sqrt``."""
    exact_arithmetic()
    py = python_function(fn)
    key = id(py)
    if key in _DEVICE:
        return _DEVICE[key][1]
    names = dict(py.__globals__)
    for name in _global_names(py.__code__):
        value = names.get(name)
        if value is llvm_math.sqrt:
            names[name] = math.sqrt
        elif isinstance(value, CPUDispatcher):
            names[name] = device_function(value)
    clone = types.FunctionType(py.__code__, names, py.__name__, py.__defaults__,
                               py.__closure__)
    clone.__doc__ = py.__doc__
    dev = _cuda().jit(device=True)(clone)
    _DEVICE[key] = (py, dev)   # keep py alive: its id keys the table
    return dev


def _global_names(code) -> set:
    """Names a code object (and any code nested in it) may look up as globals."""
    out = set(code.co_names)
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            out |= _global_names(c)
    return out
