"""``sqrt`` as LLVM's intrinsic, for the contact kernels.

numba lowers ``math.sqrt`` to a call of the C library's ``sqrt``, which LLVM may only
replace by its ``llvm.sqrt`` intrinsic where it can prove the argument is not negative
(the library call may set ``errno``); a loop with such a call is not vectorised. The
intrinsic gives the same numbers (IEEE square root, NaN for a negative argument, as
numba's ``error_model="numpy"``) and lets the contact loops be compiled to SIMD code.
"""

from numba.core import types
from numba.extending import intrinsic


@intrinsic
def sqrt(typingctx, x):
    """Square root of a float64 (``llvm.sqrt.f64``)."""
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):
        fn = builder.module.declare_intrinsic("llvm.sqrt", [args[0].type])
        return builder.call(fn, args)

    return types.float64(types.float64), codegen
