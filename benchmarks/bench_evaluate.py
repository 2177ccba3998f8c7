"""Benchmark: ``evaluate --plane`` on a 1 M-point plane, the old path against the current one.

The old path is the evaluation code of revision ``f658f7a`` (before closed-form shape
classification): ``analyze/{fits,vdi,sections,evaluation}.py`` are read with ``git show`` into
a temporary package and run side by side with :func:`fringe3d.analyze.evaluation.evaluate_points`
on the same synthetic point map, in one process.

Scene: an organized 1000 x 1000 map of a tilted plane at z ~ 500 mm, 0.1 mm pitch, Gaussian
noise sigma = 0.01 mm along the normal (no outliers, so both paths must agree): the figures
(flatness F, plane RMS) must match within 1 % and equal the injected noise's range / std.
``--truth-objects`` also times picking the sphere out of a 1 M-pixel simulator-style truth (a
sphere in front of a wall, object ids 0 and 1), old and current ``truth_objects``.
``--streak`` also evaluates the plane picked by a simulator-style truth (object id 0, noise-free
plane) after moving a 2 x 20-pixel streak 40 mm off it (a fringe-order error inside the object):
the old path reports F ~ 40 mm, the current robust default the noise's range.
With ``--outliers N`` that many pixels are also moved 40 mm off the plane (the old path then
reports F ~ 40 mm; the current default drops them by the robust rule).

Example: python benchmarks/bench_evaluate.py --size 1000 --json
"""
from __future__ import annotations

import argparse
import importlib
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from fringe3d.analyze.evaluation import evaluate_points, truth_objects

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import figure  # noqa: E402  (beside this script)

OLD_REV = "f658f7a"
OLD_FILES = ("fits", "vdi", "sections", "evaluation")
ROOT = Path(__file__).resolve().parents[1]


def old_module(rev: str = OLD_REV):
    """``analyze.evaluation`` of revision ``rev``, loaded from git into a temporary package."""
    tmp = Path(tempfile.mkdtemp(prefix="fringe3d-old-eval-"))
    pkg = tmp / f"old_analyze_{rev}"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    for name in OLD_FILES:
        text = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:src/fringe3d/analyze/{name}.py"],
                              check=True, capture_output=True, text=True).stdout
        (pkg / f"{name}.py").write_text(text)
    sys.path.insert(0, str(tmp))
    return importlib.import_module(f"{pkg.name}.evaluation")


def sphere_wall_truth(size: int):
    """Truth-like namespace (``xyz``, ``mask``, ``object_id``) of a sphere (r = 40 mm, z = 450)
    in front of a wall at z = 600 mm, seen by a pinhole camera with f = 2.5 * size px."""
    v, u = np.mgrid[0:size, 0:size].astype(np.float64)
    d = np.stack([(u - size / 2) / (2.5 * size), (v - size / 2) / (2.5 * size), np.ones_like(u)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    c, r = np.array([0.0, 0.0, 450.0]), 40.0
    b = d @ c
    disc = b ** 2 - (c @ c - r * r)
    hit = disc > 0
    s = np.where(hit, b - np.sqrt(np.clip(disc, 0, None)), 600.0 / d[..., 2])
    return SimpleNamespace(xyz=s[..., None] * d, mask=np.ones(hit.shape, bool), object_id=np.where(hit, 1, 0))


def plane_normal() -> np.ndarray:
    """Unit normal of the benchmark plane (facing the camera)."""
    n = np.array([0.1, -0.05, -1.0])
    return n / np.linalg.norm(n)


def plane_map(size: int, sigma: float, outliers: int = 0, seed: int = 0):
    """(size, size, 3) float32 map of a tilted plane and the injected normal noise (mm)."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:size, 0:size].astype(np.float64)
    x, y = (u - size / 2) * 0.1, (v - size / 2) * 0.1
    n = plane_normal()
    z = 500.0 - (n[0] * x + n[1] * y) / n[2]
    noise = rng.normal(0, sigma, (size, size))
    P = np.stack([x, y, z], -1) + noise[..., None] * n
    if outliers:
        k = rng.choice(size * size, outliers, replace=False)
        P.reshape(-1, 3)[k] += 40.0 * n
    return P.astype(np.float32), noise


def timed(fn, *a, **kw):
    t = time.perf_counter()
    r = fn(*a, **kw)
    return r, time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=1000, help="map side (pixels); 1000 = 1 M points")
    ap.add_argument("--sigma", type=float, default=0.01, help="noise std along the normal (mm)")
    ap.add_argument("--outliers", type=int, default=0, help="pixels moved 40 mm off the plane")
    ap.add_argument("--skip-old", action="store_true", help="time only the current path")
    ap.add_argument("--repeat", type=int, default=1, help="runs of the current path (best time kept); the old "
                    "path runs once")
    ap.add_argument("--truth-objects", action="store_true", help="also time truth_objects(kind='sphere')")
    ap.add_argument("--streak", action="store_true", help="also compare F with a 40 mm streak inside the truth's plane")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    P, noise = plane_map(a.size, a.sigma, a.outliers)
    runs = [timed(evaluate_points, P, plane=True) for _ in range(max(1, a.repeat))]
    new, t_new = runs[0][0], min(t for _, t in runs)
    rep = {"points": int(P.shape[0] * P.shape[1]), "sigma_mm": a.sigma, "outliers": a.outliers,
           "noise_range_mm": float(np.ptp(noise)), "noise_std_mm": float(np.std(noise)),
           "new": {"seconds": t_new, "flatness": new["plane"]["flatness"], "rms": new["plane"]["rms"]}}
    if not a.skip_old:
        old_mod = old_module()
        old, t_old = timed(old_mod.evaluate_points, P, plane=True)
        rep["old"] = {"revision": OLD_REV, "seconds": t_old, "flatness": old["plane"]["flatness"],
                      "rms": old["plane"]["rms"]}
        rep["speedup"] = t_old / t_new
        if not a.outliers:
            for k in ("flatness", "rms"):
                rep[f"{k}_rel_diff"] = abs(new["plane"][k] - old["plane"][k]) / old["plane"][k]
    if a.truth_objects:
        t = sphere_wall_truth(a.size)
        objs, t_objs = timed(truth_objects, t, "sphere")
        rep["truth_objects"] = {"new_seconds": t_objs, "new_ids": [o for o, _ in objs]}
        if not a.skip_old:
            objs, t_objs = timed(old_mod.truth_objects, t, "sphere")
            rep["truth_objects"].update(old_seconds=t_objs, old_ids=[o for o, _ in objs])
    if a.streak:
        n = plane_normal()
        clean = P.astype(np.float64) - noise[..., None] * n
        t = SimpleNamespace(xyz=clean, mask=np.ones(noise.shape, bool), object_id=np.zeros(noise.shape, int))
        Q = P.copy()
        Q[50:52, 60:80] += (40.0 * n).astype(np.float32)
        rep["streak"] = {"new_flatness": evaluate_points(Q, t, plane=True)["plane"]["flatness"]}
        if not a.skip_old:
            rep["streak"]["old_flatness"] = old_mod.evaluate_points(Q, t, plane=True)["plane"]["flatness"]
    group = f"evaluate --plane, {rep['points']} points"
    rep["figures"] = [figure(group, "evaluate_points (current)", "ours", "s", [t for _, t in runs])]
    if not a.skip_old:
        rep["figures"].append(figure(group, f"the evaluation of {OLD_REV}", "reference", "s", [rep["old"]["seconds"]]))
    if a.json:
        print(json.dumps(rep, indent=1))
    else:
        for k, v in rep.items():
            print(f"{k:>18}: {v}")
    ok = a.outliers or a.skip_old or (rep["flatness_rel_diff"] < 0.01 and rep["rms_rel_diff"] < 0.01)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
