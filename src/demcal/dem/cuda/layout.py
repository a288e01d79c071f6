"""Array layouts the CUDA backend's modules share (no numba.cuda import, so that
:mod:`.backend` can read them before numba-cuda is known to be installed)."""

#: Columns of a pair slot's terms for the gather (:mod:`.kernels`): force on i, i's
#: torque term, j's torque term.
SLOT_OUT_WIDTH = 9
