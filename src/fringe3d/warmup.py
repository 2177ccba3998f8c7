"""Compile the measurement kernels once, ahead of the first real frame (``fringe3d warmup``).

numba compiles a kernel on its first call and keeps the machine code on disk (``cache=True``), so
the first 3D frame after an install otherwise pays seconds of compilation. :func:`warm_up` runs
the two per-cycle paths a user meets first on a tiny simulated capture, in a temporary folder that
is removed afterwards:

* the decode path (``decode`` + triangulation) on the tiny preset's default capture, and the
  undistortion of a distorted camera's ray table;
* the fused 3-step + geometric-constraint path (:class:`fringe3d.reconstruct.FastThreeStep`) on a
  3-step capture, with every default output (quality, sigma_z, texture), and the point store's
  float16 cast of sigma_z.

The kernels are specialised on array types, not sizes, so a tiny capture compiles what a
1280x1024 camera uses. Nothing is written outside the temporary folder and numba's own cache.
"""
from __future__ import annotations

import tempfile
import time
import warnings
from pathlib import Path
from typing import Callable

import numpy as np

from fringe3d.decode import DecodeOptions
from fringe3d.io._float16 import to_float16
from fringe3d.io.capture import read_capture
from fringe3d.optics import Rig
from fringe3d.optics.distortion import undistort
from fringe3d.patterns import sets
from fringe3d.pipeline import reconstruct_capture
from fringe3d.reconstruct.frame import FrameReconstructor, reconstruction_plans
from fringe3d.sim import simulate_capture

#: Nearest depth (mm) of the tiny preset's working volume, for the geometric constraint.
TINY_Z_MIN = 340.0


def _decode_path(folder: Path) -> None:
    cap = folder / "decode-path"
    simulate_capture(cap, preset="tiny", seed=0, progress=False)
    reconstruct_capture(cap, cap / "rig.json")
    # the tiny camera has no lens distortion; a calibrated one has: its ray table's Newton kernel
    undistort(np.zeros((1, 2)), (-0.08, 0.1, 0.0, 0.0, 0.0))


def _fused_path(folder: Path) -> None:
    cap = folder / "fused-path"
    ps = sets.phase_shift(64, 3, "v", width=256, height=200)
    simulate_capture(cap, preset="tiny", scene="sphere", patterns=ps, seed=0, progress=False)
    capture = read_capture(cap)
    rec = FrameReconstructor(reconstruction_plans(capture.patterns, "geometric"), Rig.load(cap / "rig.json"),
                             DecodeOptions(z_min=TINY_Z_MIN))
    rec.reconstruct(capture.frames[:3])
    # a sequence's window (sigma_z alone, sigma_z_kernel) and the point store's float16 cast of it
    cycle = rec.reconstruct(capture.frames[:3], uncertainty="z", points=False, texture=False)
    if cycle.sigma_z is not None:
        to_float16(cycle.sigma_z)


#: The warmed paths in the order :func:`warm_up` runs them.
PATHS: dict[str, Callable[[Path], None]] = {"decode + triangulate": _decode_path,
                                            "fused 3-step + geometric": _fused_path}


def warm_up(announce: Callable[[str], None] | None = None) -> list[dict]:
    """Run every path of :data:`PATHS` once on tiny simulated captures.

    Parameters
    ----------
    announce : callable, optional
        Called with a line before each path (the command's progress output).

    Returns
    -------
    list of dict
        One ``{"path": name, "seconds": float}`` per path: the first call compiles (or loads
        from numba's cache), so a second run shows what is left after warming.
    """
    done = []
    with tempfile.TemporaryDirectory(prefix="fringe3d-warmup-") as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a tiny synthetic capture: its warnings are not the user's
        for name, run in PATHS.items():
            if announce is not None:
                announce(f"warming the {name} path")
            t0 = time.perf_counter()
            run(Path(tmp))
            done.append({"path": name, "seconds": round(time.perf_counter() - t0, 2)})
    return done
