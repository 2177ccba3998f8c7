"""Cost of a whole-object merge: seconds per view and peak memory of register + fuse + mesh.

Run: ``.venv/bin/python benchmarks/bench_multiview.py [--views 12] [--preset macro] [--json]``
(not a test). The views are the ``macro`` preset's 1280x1024 camera looking at the sculpture on
the virtual turntable (10 degree steps), made once by ray casting the truth plus depth noise
(:func:`fringe3d.sim.turntable.turntable_views`: what ``fringe3d reconstruct`` would give, without
rendering and decoding 12 fringe captures) and cached under ``--cache`` (default
``/tmp/fringe3d-bench-multiview``). The merge then runs in a child process, as ``fringe3d merge``
does: stage poses off by 2 mrad / 0.2 mm with the stage prior, point-to-plane ICP and pose graph,
sigma-weighted fusion, screened Poisson mesh. Reported: each stage's seconds, seconds per view,
and CPU seconds (``process_time``: wall time on a shared machine says more about the neighbours), the
child's peak resident set size (``ru_maxrss`` of ``getrusage(RUSAGE_SELF)``, what
``/usr/bin/time -v`` calls "Maximum resident set size"; the parent stays small so the child
inherits no high-water mark from it), then the accuracy against the truth (not timed).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import figure  # noqa: E402  (beside this script)

ROOT = Path(__file__).resolve().parents[1]


def _cache_dir(a) -> Path:
    return Path(a.cache) / f"{a.preset}-{a.views}v-{a.step:g}deg-seed{a.seed}"


def generate(a) -> None:
    """Child: ray-cast the views and write them (float32) with the truth into the cache."""
    import numpy as np

    from fringe3d.sim import presets
    from fringe3d.sim.turntable import sculpture_turntable, turntable_views

    p = presets.get(a.preset)
    angles = a.step * (np.arange(a.views) - 0.5 * (a.views - 1))
    scan = turntable_views(sculpture_turntable(p, seed=a.seed), p, angles, sigma=0.05, seed=a.seed)
    d = _cache_dir(a)
    d.mkdir(parents=True, exist_ok=True)
    for k, (P, s) in enumerate(zip(scan.points, scan.sigma)):
        np.savez(d / f"view-{k:02d}.npz", points=P.astype(np.float32), sigma=s.astype(np.float32))
    rng = np.random.default_rng(a.seed)
    keep = rng.choice(len(scan.truth_points), min(len(scan.truth_points), 400_000), replace=False)
    np.savez(d / "truth.npz", poses=scan.true_poses, points=scan.truth_points[keep].astype(np.float32),
             normals=scan.truth_normals[keep].astype(np.float32), angles=scan.angles_deg)
    (d / "done").write_text("ok")


def run(a) -> dict:
    """Child: merge the cached views, timing each stage; print the figures as JSON."""
    import resource
    import time

    import numpy as np

    from fringe3d.multiview.fuse import fuse_views
    from fringe3d.multiview.mesh import poisson_mesh
    from fringe3d.multiview.register import register_views
    from fringe3d.multiview.views import view_from_map
    from fringe3d.sim.turntable import stage_errors

    d = _cache_dir(a)
    t0 = time.perf_counter()
    views = []
    for k in range(a.views):
        z = np.load(d / f"view-{k:02d}.npz")
        views.append(view_from_map(f"view-{k:02d}", z["points"].astype(float), z["sigma"].astype(float)))
    truth = np.load(d / "truth.npz")
    true = truth["poses"]
    c = truth["points"].astype(float).mean(0)
    cents = [np.linalg.inv(T)[:3, :3] @ c + np.linalg.inv(T)[:3, 3] for T in true]
    stage = stage_errors(true, cents, 2.0, 0.2, seed=a.seed + 1)
    t_read = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    reg = register_views(views, stage, voxel=a.voxel, stage_sigma=(2.0, 0.2))
    t_reg, c_reg = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    fused = fuse_views(views, reg.poses, 0.5 * a.voxel)
    t_fuse, c_fuse = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    mesh = poisson_mesh(fused.points, 0.5 * a.voxel)
    t_mesh, c_mesh = time.perf_counter() - t0, time.process_time() - c0
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB
    hwm = [x for x in open("/proc/self/status") if x.startswith("VmHWM:")][0].split()[1]

    from fringe3d.multiview.accuracy import coverage, hausdorff, pose_errors, rms, surface_distances
    from fringe3d.multiview.fuse import place
    tp, tn = truth["points"].astype(float), truth["normals"].astype(float)
    rot, tra = pose_errors(reg.poses, true, c)
    single = float(np.mean([rms(surface_distances(place(v, P), tp, tn)) for v, P in zip(views, true)]))
    fused_rms = rms(surface_distances(fused.points, tp, tn))
    mv = np.asarray(mesh.vertices)
    total = t_reg + t_fuse + t_mesh
    return {"preset": a.preset, "views": a.views, "step_deg": a.step, "voxel_mm": a.voxel,
            "points_per_view": float(np.mean([len(v.points) for v in views])),
            "seconds": {"read": round(t_read, 2), "register": round(t_reg, 2), "fuse": round(t_fuse, 2),
                        "mesh": round(t_mesh, 2), "register_fuse_mesh": round(total, 2)},
            "cpu_seconds": {"register": round(c_reg, 2), "fuse": round(c_fuse, 2), "mesh": round(c_mesh, 2)},
            "seconds_per_view": round(total / a.views, 2),
            "cpu_seconds_per_view": round((c_reg + c_fuse + c_mesh) / a.views, 2),
            "cpus": os.cpu_count(), "load_average_1min": os.getloadavg()[0],
            "peak_rss_mb": round(peak_mb, 1), "vm_hwm_mb": round(int(hwm) / 1024.0, 1),
            "rotation_error_mrad": {"max": float(rot.max()), "mean": float(rot[1:].mean())},
            "translation_error_um": {"max": float(tra.max()), "mean": float(tra[1:].mean())},
            "rotation_sigma_mrad_max": float(np.nanmax(reg.rotation_sigma_mrad)),
            "single_view_rms_mm": single, "fused_rms_mm": fused_rms, "fused_over_single": fused_rms / single,
            "coverage": coverage(fused.points, tp, a.voxel), "fused_points": len(fused.points),
            "mesh_rms_mm": rms(surface_distances(mv, tp, tn)), "mesh_hausdorff_mm": hausdorff(mv, tp),
            "mesh_triangles": len(mesh.triangles)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", type=int, default=12)
    ap.add_argument("--step", type=float, default=10.0, help="table turn between views (deg)")
    ap.add_argument("--preset", default="macro", help="macro: 1280x1024 camera")
    ap.add_argument("--voxel", type=float, default=1.0, help="registration sampling (mm); fusion half of it")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", default="/tmp/fringe3d-bench-multiview")
    ap.add_argument("--child", choices=("generate", "run"), help=argparse.SUPPRESS)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    if a.child == "generate":
        generate(a)
        return
    if a.child == "run":
        print(json.dumps(run(a)))
        return
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    base = [sys.executable, __file__, "--views", str(a.views), "--step", str(a.step), "--preset", a.preset,
            "--voxel", str(a.voxel), "--seed", str(a.seed), "--cache", a.cache]
    if not (_cache_dir(a) / "done").is_file():
        print(f"generating {a.views} views into {_cache_dir(a)} (once) ...", file=sys.stderr)
        subprocess.run([*base, "--child", "generate"], env=env, check=True)
    out = subprocess.run([*base, "--child", "run"], env=env, check=True, stdout=subprocess.PIPE, text=True)
    fig = json.loads(out.stdout.strip().splitlines()[-1])
    group = f"multi-view merge: register + fuse + mesh, {fig['views']} views, {fig['preset']}"
    fig["figures"] = [figure(group, "seconds per view (wall)", "ours", "s", [fig["seconds_per_view"]]),
                      figure(group, "seconds per view (CPU)", "reference", "s", [fig["cpu_seconds_per_view"]]),
                      figure(group, "peak resident set size", "ours", "MB", [fig["peak_rss_mb"]])]
    if a.json:
        print(json.dumps(fig, indent=1))
        return
    s = fig["seconds"]
    print(f"{fig['views']} views of {fig['preset']} ({fig['points_per_view']:.0f} points/view), voxel {a.voxel} mm")
    print(f"register {s['register']} s, fuse {s['fuse']} s, mesh {s['mesh']} s: "
          f"{fig['seconds_per_view']} s/view wall, {fig['cpu_seconds_per_view']} s/view CPU (load "
          f"{fig['load_average_1min']:.1f} on {fig['cpus']} CPUs); peak RSS {fig['peak_rss_mb']} MB")
    print(f"pose error: rotation max {fig['rotation_error_mrad']['max']:.3f} mrad, translation max "
          f"{fig['translation_error_um']['max']:.1f} um; fused RMS {fig['fused_rms_mm']:.4f} mm = "
          f"{fig['fused_over_single']:.2f} x single-view; coverage {100 * fig['coverage']:.2f} %; mesh RMS "
          f"{fig['mesh_rms_mm']:.4f} mm, Hausdorff {fig['mesh_hausdorff_mm']:.3f} mm")


if __name__ == "__main__":
    main()
