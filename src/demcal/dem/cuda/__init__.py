"""The CUDA backend (numba-cuda): the CPU kernels' source compiled for the GPU.

:mod:`.compile` makes the device functions, :mod:`.kernels` the grid drivers and
:mod:`.backend` the backend the :class:`~demcal.dem.Simulation` calls. Importing this
package does not import numba.cuda; choosing the backend does.
"""
