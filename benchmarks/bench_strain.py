"""Benchmark: geodesic tracking + bending strain per 3D frame on the simulator's flapping wing.

The strain stage of ``fringe3d strain`` (:func:`fringe3d.analyze.strain.wing_sequence`: two
geodesic distance maps per frame, Eq. 6.7–6.8; tracking, Eq. 6.9; local quadric fits and the
Kirchhoff–Love strain, Eq. 6.10–6.21) timed in ONE run for

* ``old``: the geodesic search of commit 428e8f5 (``git show 428e8f5:src/fringe3d/analyze/
  geodesic.py`` loaded as a module): every node recomputes its 32 Bézier step lengths and the
  wavefront triangles' far sides, per anchor, over the whole map;
* ``new``: the current code: every step length once per frame (:func:`fringe3d.analyze.geodesic.
  step_table`: a vectorised kernel over the valid pixels' bounding box, two row ranges on two
  threads, reverse steps reused), shared by the two anchors, whose searches on that table run at
  once on two threads (:func:`fringe3d.analyze.geodesic.table_geodesics`), each stopped at
  (1 + 0.1) × the farthest query point's reference distance. The distances are the old search's
  bit for bit (``max_uv_difference_px`` compares the tracked positions).

Input: noise-free ray-cast point maps of :func:`fringe3d.experiments.flapping_wing.sim_wing`
(150 × 70 mm, 25 Hz beat) seen by the ``high-speed`` preset's camera with its intrinsics scaled
by ``--scale`` (2: 1280 × 1024 px), ``--frames`` 3D frames 2.5 ms apart, exact anchors, the five
Table 6.1 markers plus an interior grid every ``--step`` px. Errors against the analytic wing:
tracking RMS (mm, markers, over the deformed frames) and the dominant-strain RMS error (µε and
% of peak, grid points) as in the experiment's strain table.

Seconds per 3D frame: median over the deformed frames of the time between frames (distance maps
+ tracking + fits + strain), the reference frame (numba compilation) excluded.

``--workers 1,2``: the deformed frames again through the pipeline's frame scheduler
(:func:`fringe3d.analyze.wing_strain.frames_in_order`, what ``fringe3d strain --workers N`` runs)
on N threads: wall seconds / deformed frames for each N, and whether the results equal one
worker's bit for bit.

``--dask 2``: the same frames as :class:`fringe3d.analyze.frame_task.StrainFrameTask` tasks on a
LocalCluster of N worker processes (:func:`fringe3d.cluster.strain_frames.frames_on_dask`, what
``fringe3d strain --dask-workers N`` runs; the maps saved to a temporary .npy the workers read):
wall seconds / deformed frames of a second pass (the first loads numba's kernels in every
worker; its time is reported too, cluster start excluded), the pickled task's size (what is
scattered to every worker once) and one frame's pickled results (what comes back per frame),
and whether the results equal one thread's bit for bit.

Example: python benchmarks/bench_strain.py --scale 2 --frames 4 --json
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import json
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import fringe3d.analyze.strain as strain_mod
from fringe3d.analyze.anchors import check_anchor
from fringe3d.analyze.frame_task import StrainFrameTask
from fringe3d.analyze.strain import TrackingSettings, wing_frame, wing_reference, wing_sequence
from fringe3d.analyze.wing_strain import frames_in_order
from fringe3d.experiments import flapping_wing as fw
from fringe3d.optics.pinhole import intrinsics
from fringe3d.sim import presets

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import figure  # noqa: E402  (beside this script)

OLD_REV = "428e8f5"


def old_geodesic_module():
    """The geodesic module of ``OLD_REV`` loaded from ``git show`` (numba cache in a temp dir)."""
    root = Path(__file__).resolve().parents[1]
    src = subprocess.run(["git", "show", f"{OLD_REV}:src/fringe3d/analyze/geodesic.py"], cwd=root,
                         capture_output=True, text=True, check=True).stdout
    path = Path(tempfile.mkdtemp(prefix="geodesic_old_")) / "geodesic_old.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("geodesic_old", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def scaled_camera(scale: int):
    """The high-speed preset's camera with ``scale`` × the pixels (same field of view)."""
    cam = presets.get("high-speed").rig.camera
    K = cam.K
    Ks = intrinsics(K[0, 0] * scale, K[1, 1] * scale, (K[0, 2] + 0.5) * scale - 0.5, (K[1, 2] + 0.5) * scale - 0.5)
    return dataclasses.replace(cam, K=Ks, width=cam.width * scale, height=cam.height * scale)


def run_stage(maps, anchors, q, window, distance_maps=None, stop_margin=0.1):
    """wing_sequence on ``maps``; returns (result, per-frame seconds (F,)). ``distance_maps``
    replaces the library's for the run (the old path)."""
    stamps = [time.perf_counter()]
    saved = strain_mod.distance_maps
    if distance_maps is not None:
        strain_mod.distance_maps = distance_maps
    try:
        res = wing_sequence(maps, anchors, q, fw.THICKNESS, TrackingSettings(window=window, stop_margin=stop_margin),
                            progress=lambda: stamps.append(time.perf_counter()))
    finally:
        strain_mod.distance_maps = saved
    return res, np.diff(stamps)


def run_workers(maps, anchors, q, window, workers):
    """Wall seconds per deformed 3D frame of wing_frame over ``workers`` threads, and its uv (F-1, N, 2)."""
    ref = wing_reference(maps[0], anchors[0], q, fw.THICKNESS, TrackingSettings(window=window))
    t0 = time.perf_counter()
    got = [r.uv for _, r in frames_in_order(lambda f: wing_frame(ref, maps[f + 1], anchors[f + 1], f + 1),
                                            len(maps) - 1, workers)]
    return (time.perf_counter() - t0) / (len(maps) - 1), np.stack(got)


def run_dask(maps, anchors, q, window, workers):
    """The deformed frames as StrainFrameTask tasks on a LocalCluster of ``workers`` processes:
    {seconds per 3D frame of the second pass, of the first, task MB, result bytes per frame}, uv (F-1, N, 2)."""
    from fringe3d.cluster.engine import close, connect
    from fringe3d.cluster.strain_frames import frames_on_dask

    path = Path(tempfile.mkdtemp(prefix="bench_strain_")) / "points.npy"
    np.save(path, np.stack(maps))
    ref = wing_reference(maps[0], anchors[0], q, fw.THICKNESS, TrackingSettings(window=window))
    task = StrainFrameTask(str(path), 0, (ref,), np.asarray(anchors)[:, None])
    client = connect(workers=workers)
    try:
        frames, n, secs = frames_on_dask(client), len(maps), []
        for _ in range(2):
            t0 = time.perf_counter()
            got = [r[0].uv for f, r in frames(task, n) if f > 0]
            secs.append((time.perf_counter() - t0) / (n - 1))
        sizes = {"task_mb": len(pickle.dumps(task)) / 1e6, "result_bytes_per_frame": len(pickle.dumps(task(1)))}
    finally:
        close(client, own_cluster=True)
        path.unlink()
    return {"s_per_3d_frame": secs[1], "first_pass_s_per_3d_frame": secs[0], **sizes}, np.stack(got)


def errors(res, wing, cam_project_truth, m0, t3, n_markers):
    """Tracking RMS (mm) of the markers over the deformed frames; strain RMS (µε), % of peak."""
    e = res.xyz[1:, :n_markers] - cam_project_truth[1:]
    track = float(np.sqrt(np.nanmean(np.sum(e ** 2, axis=2))))
    rms, _med, peak, n = fw._strain_vs_truth(wing, res, n_markers, m0, t3)
    return {"tracking_rms_mm": track, "strain_rms_ue": 1e6 * rms, "strain_rms_pct_peak": 100 * rms / peak,
            "strain_points": n, "tracked_fraction": float(res.ok[1:].mean())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scale", type=int, default=2, help="pixels × the preset camera (2: 1280×1024)")
    ap.add_argument("--frames", type=int, default=4, help="3D frames (the first is the reference)")
    ap.add_argument("--step", type=int, default=16, help="interior grid step (px at scale 1)")
    ap.add_argument("--window", type=int, default=11, help="quadric-fit window (px at scale 1)")
    ap.add_argument("--workers", default="", help="comma-separated thread counts to time, e.g. 1,2")
    ap.add_argument("--dask", default="", help="comma-separated Dask worker-process counts to time, e.g. 2")
    ap.add_argument("--no-old", action="store_true", help="skip the old geodesic search")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    cam = scaled_camera(args.scale)
    window = args.window * args.scale + (1 - (args.window * args.scale) % 2)   # odd
    wing = fw.sim_wing()
    t3 = np.arange(args.frames) / (fw.BEAT * 16)
    maps, m0 = [], None
    for t in t3:
        P, M = fw.truth_map(wing, cam, t)
        maps.append(P)
        m0 = M if m0 is None else m0
    anchors = np.stack([cam.project(wing.material_to_world(fw.SIM_ANCHORS, t)) for t in t3])
    q_mark = cam.project(wing.material_to_world(fw.SIM_MARKERS, t3[0]))
    grid, _ = fw.interior_grid(np.isfinite(maps[0]).all(axis=2), anchors[0], window, args.step * args.scale)
    q = np.vstack([q_mark, grid])
    truth_xyz = np.stack([wing.material_to_world(fw.SIM_MARKERS, t) for t in t3])

    old = old_geodesic_module()

    def old_distance_maps(points, anchors_uv, method="bezier", radius=3, stop_distance=None):
        for a in anchors_uv:
            check_anchor(points, a)
        return old.bezier_geodesic(points, anchors_uv[0]), old.bezier_geodesic(points, anchors_uv[1])

    res_new, dt_new = run_stage(maps, anchors, q, window)
    res_old, dt_old = (res_new, dt_new) if args.no_old else run_stage(maps, anchors, q, window, old_distance_maps,
                                                                      stop_margin=None)
    out = {"resolution": f"{cam.width}x{cam.height}", "wing_pixels": int(np.isfinite(maps[0]).all(axis=2).sum()),
           "frames": args.frames, "points": int(len(q)), "window_px": window, "load_avg": os.getloadavg()[0]}
    for name, res, dt in (("old", res_old, dt_old), ("new", res_new, dt_new)):
        out[name] = {"s_per_3d_frame": float(np.median(dt[1:])), "s_frames": [round(float(x), 3) for x in dt[1:]],
                     **errors(res, wing, truth_xyz, m0, t3, len(fw.SIM_MARKERS))}
    out["speedup"] = out["old"]["s_per_3d_frame"] / out["new"]["s_per_3d_frame"]
    uv1 = None
    for nw in [int(x) for x in args.workers.split(",") if x]:
        sec, uv = run_workers(maps, anchors, q, window, nw)
        uv1 = uv if uv1 is None else uv1
        out[f"workers_{nw}"] = {"s_per_3d_frame": sec, "equal_to_first": bool(np.array_equal(uv, uv1, equal_nan=True))}
    for nd in [int(x) for x in args.dask.split(",") if x]:
        rd, uv = run_dask(maps, anchors, q, window, nd)
        uv1 = uv if uv1 is None else uv1
        out[f"dask_{nd}"] = {**rd, "equal_to_first": bool(np.array_equal(uv, uv1, equal_nan=True))}
    ok = res_old.ok & res_new.ok
    out["max_uv_difference_px"] = float(np.nanmax(np.abs(res_old.uv - res_new.uv)[ok])) if ok.any() else float("nan")
    group = f"strain: geodesic tracking + bending strain per 3D frame, {out['resolution']}"
    out["figures"] = [figure(group, "wing_sequence (current geodesic search)", "ours", "s", dt_new[1:])]
    if not args.no_old:
        out["figures"].append(figure(group, "the same with the geodesic search of 428e8f5", "reference", "s",
                                     dt_old[1:]))
    out["figures"] += [figure(group, f"frame scheduler, {k.split('_')[1]} {k.split('_')[0]} (wall / frame)", "ours",
                              "s", [out[k]["s_per_3d_frame"]]) for k in out if k.startswith(("workers_", "dask_"))]
    out["groups"] = {group: {"scene": "simulated flapping wing, noise-free ray-cast maps (no fringes to unwrap)"}}
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        print(f"{out['resolution']} wing {out['wing_pixels']} px, {out['points']} points, {args.frames} frames, "
              f"load {out['load_avg']:.1f}")
        for name in ("old", "new"):
            r = out[name]
            print(f"{name:4s} {r['s_per_3d_frame']:.3f} s/3D frame  tracking RMS {r['tracking_rms_mm'] * 1e3:.2f} µm  "
                  f"strain RMS {r['strain_rms_ue']:.2f} µε ({r['strain_rms_pct_peak']:.2f} % of peak)  "
                  f"tracked {100 * r['tracked_fraction']:.1f} %")
        print(f"speedup {out['speedup']:.1f}x; max |Δuv| old vs new {out['max_uv_difference_px']:.2e} px")
        for k in [k for k in out if k.startswith(("workers_", "dask_"))]:
            r = out[k]
            print(f"{k}: {r['s_per_3d_frame']:.3f} s/3D frame (wall), equal to the first: {r['equal_to_first']}")
            if k.startswith("dask_"):
                print(f"  first pass {r['first_pass_s_per_3d_frame']:.3f} s/3D frame; task {r['task_mb']:.1f} MB "
                      f"scattered once; {r['result_bytes_per_frame']} B of results per frame")
    return 0


if __name__ == "__main__":
    sys.exit(main())
