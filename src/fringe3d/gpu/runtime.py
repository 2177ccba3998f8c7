"""Choosing the backend and loading ``numba.cuda`` lazily, with a clear error when it cannot run.

``numba.cuda`` is imported on the first ``backend="cuda"`` call only. Under numba's CUDA
simulator (``NUMBA_ENABLE_CUDASIM=1``, set before numba is imported) the kernels run on the CPU
in Python: that is how they are tested without a GPU.
"""
from __future__ import annotations

import importlib

#: The backends of the per-pixel kernels: ``"cpu"`` (numba, parallel rows) and ``"cuda"``.
BACKENDS = ("cpu", "cuda")


class CudaUnavailableError(RuntimeError):
    """``backend="cuda"`` was asked for but cannot run here: numba's CUDA target is not
    installed, or there is no CUDA driver or device. The message says which."""


_ADVICE = ("run with the cpu backend (`backend='cpu'`), or check the NVIDIA driver and "
           "CUDA_VISIBLE_DEVICES")


def check_backend(backend: str) -> str:
    """Check that ``backend`` is one of :data:`BACKENDS`.

    Parameters
    ----------
    backend : str
        The backend name.

    Returns
    -------
    str
        ``backend`` itself.

    Raises
    ------
    ValueError
        An unknown backend (the message names the choices).
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; expected one of {', '.join(BACKENDS)}")
    return backend


def cuda_module():
    """``numba.cuda``, once it is known to work here (a device, or the simulator).

    Returns
    -------
    module
        ``numba.cuda``.

    Raises
    ------
    CudaUnavailableError
        When ``numba.cuda`` cannot be imported (install the extra: ``pip install
        'fringe3d[cuda]'``), or no CUDA driver / device is found.
    """
    try:
        cuda = importlib.import_module("numba.cuda")
    except ImportError as e:
        raise CudaUnavailableError(f"the CUDA backend needs numba-cuda, which is not installed ({e}); install "
                                   "it with: pip install 'fringe3d[cuda]'") from None
    except Exception as e:  # numba.cuda checks NUMBA_CUDA_DRIVER & co. on import  # noqa: BLE001
        raise CudaUnavailableError(f"the CUDA backend found no usable CUDA driver ({type(e).__name__}: {e}); "
                                   f"{_ADVICE}") from None
    if simulator_enabled():
        return cuda
    try:
        ok = bool(cuda.is_available())
    except Exception as e:  # a broken driver install raises from inside numba  # noqa: BLE001
        raise CudaUnavailableError(f"the CUDA backend found no usable CUDA driver ({type(e).__name__}: {e}); "
                                   f"{_ADVICE}") from None
    if not ok:
        raise CudaUnavailableError("the CUDA backend found no CUDA driver or no CUDA device on this machine "
                                   f"(numba.cuda.is_available() is False); {_ADVICE}")
    return cuda


def simulator_enabled() -> bool:
    """True when numba runs CUDA kernels in its simulator (``NUMBA_ENABLE_CUDASIM=1``)."""
    try:
        from numba.core import config
    except ImportError:  # pragma: no cover - numba is a core dependency
        return False
    return bool(getattr(config, "ENABLE_CUDASIM", 0))


def is_device_array(a) -> bool:
    """True when ``a`` lives on the device (a numba CUDA array or the simulator's stand-in)."""
    return hasattr(a, "copy_to_host") and not isinstance(a, type(None))
