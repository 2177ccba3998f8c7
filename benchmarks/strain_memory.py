"""Peak memory of ``fringe3d strain`` (:func:`fringe3d.analyze.wing_strain.run_strain`) against the
sequence length: a zarr store of N float32 640 × 512 frames of the tests' analytic wing (one
chunk per frame), tracked every 8 px without figures; prints the peak resident set size (MB).

Run once per length, in fresh processes, and compare (memory must not grow with N beyond the
per-point results, ~N · 100 B per tracked point):

    PYTHONPATH=src python benchmarks/strain_memory.py 4
    PYTHONPATH=src python benchmarks/strain_memory.py 48
"""
from __future__ import annotations

import resource
import sys
import tempfile
from pathlib import Path

import numpy as np
import zarr

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from conftest import ANCHORS, AnalyticWing, camera, point_map  # noqa: E402

from fringe3d.analyze.strain import TrackingSettings  # noqa: E402
from fringe3d.analyze.wing_strain import StrainSettings, run_strain  # noqa: E402


def main(n: int) -> None:
    cam = camera(640, 512, 1000.0)
    wing = AnalyticWing(np.array([-75.0, -35.0, 560.0]), +1, curvature=lambda t: 1 / 500 + t * 0.2,
                        flap=lambda t: np.deg2rad(60.0) * t)
    P = point_map([wing], cam, 0.0)[0].astype(np.float32)
    d = tempfile.mkdtemp()
    arr = zarr.open_group(d + "/s.zarr", mode="w").create_array("points", shape=(n,) + P.shape, dtype="f4",
                                                                 chunks=(1,) + P.shape)
    for i in range(n):
        arr[i] = P
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    an = np.array([cam.project(wing.world(*x, 0.0)) for x in ANCHORS])
    s = run_strain(d + "/s.zarr", ",".join(f"{x:.3f}" for x in an.ravel()), Path(d) / "o",
                   StrainSettings(step=8, tracking=TrackingSettings(fill_dots=0)), figures=False)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{n} frames {P.shape}: peak RSS {peak:.0f} MB (before the run {before:.0f} MB), {s['seconds']} s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 16)
