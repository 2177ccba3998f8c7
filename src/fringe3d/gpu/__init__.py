"""CUDA backend of the per-pixel work (wrapped phase, three-frequency decode, geometric
unwrapping, closed-form and fused 3-step triangulation), written with ``numba.cuda``.

Nothing here imports ``numba.cuda`` at import time: :func:`fringe3d.gpu.runtime.cuda_module`
loads it (and checks for a driver and a device) the first time a ``backend="cuda"`` call is
made, so the CPU path never needs it. The kernels take plain arrays; the layers above (phase,
unwrap, reconstruct) pass theirs in. See ``docs/gpu.md``.
"""
from fringe3d.gpu.runtime import BACKENDS, CudaUnavailableError, check_backend, cuda_module

__all__ = ["BACKENDS", "CudaUnavailableError", "check_backend", "cuda_module"]
