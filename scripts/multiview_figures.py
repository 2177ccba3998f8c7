"""Multi-view figures on the virtual turntable (issue 26): registration error vs the true poses,
fused-cloud and mesh accuracy vs the truth surface, coverage, VDI/VDE 2634-3 sphere spacing, cost.

Views are truth ray-casts plus depth noise (σ = 0.05 mm / max(cos θ, 0.3)) of the
``high-speed`` preset's 640×512 camera (0.4 mm/px at 400 mm), not fringe images through decode.

    PYTHONPATH=src /usr/bin/time -v python scripts/multiview_figures.py [--seed 0] [--scene both]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from fringe3d.analyze.vdi import multiview_sphere_spacing
from fringe3d.devices.stage import rotation_about
from fringe3d.multiview.accuracy import coverage, hausdorff, pose_errors, rms, surface_distances
from fringe3d.multiview.fuse import place
from fringe3d.multiview.merge import merge_views
from fringe3d.multiview.mesh import mesh_figures
from fringe3d.multiview.register import AmbiguousRegistration
from fringe3d.multiview.views import view_from_map
from fringe3d.sim import presets
from fringe3d.sim.turntable import sculpture_turntable, sphere_bar_scene, turntable_views

VOXEL = 1.0  # mm registration sampling; fusion 0.5 mm


def _rough(poses, centre, rng):
    """Stage poses with a 5 mrad / 0.5 mm error per view (an uncalibrated table)."""
    out = [poses[0]]
    for P in poses[1:]:
        T = rotation_about(rng.normal(size=3), 0.005, centre)
        T[:3, 3] += rng.normal(size=3) * 0.5 / np.sqrt(3)
        out.append(P @ T)
    return np.stack(out)


def run(name, scene, preset, angles, seed, centres=None, radius=None):
    t0 = time.perf_counter()
    scan = turntable_views(scene, preset, angles, sigma=0.05, seed=seed)
    t_sim = time.perf_counter() - t0
    views = [view_from_map(f"v{i:02d}", P, s) for i, (P, s) in enumerate(zip(scan.points, scan.sigma))]
    c = scan.truth_points.mean(0)
    single = [rms(surface_distances(place(v, P), scan.truth_points, scan.truth_normals))
              for v, P in zip(views, scan.true_poses)]
    print(f"\n== {name}: {len(views)} views at {angles[1] - angles[0]:g} deg steps, 640x512, "
          f"{np.mean([len(v.points) for v in views]):.0f} points/view, simulation {t_sim:.1f} s")
    print(f"single-view RMS vs truth: mean {np.mean(single):.4f} mm (max {np.max(single):.4f})")
    rng = np.random.default_rng(seed)
    rough = _rough(scan.true_poses, c, rng)
    for mode, start, prior in (("stage poses (5 mrad, 0.5 mm rough), no prior", rough, None),
                               ("stage poses (5 mrad, 0.5 mm rough), stage prior 5 mrad / 0.5 mm", rough, (5.0, 0.5)),
                               ("free-hand (FPFH + RANSAC start)", None, None)):
        t0 = time.perf_counter()
        try:
            m = merge_views(views, start, voxel=VOXEL, mesh="poisson", seed=seed, stage_sigma=prior)
        except AmbiguousRegistration as e:
            print(f"-- {mode}: refused ({time.perf_counter() - t0:.1f} s): {e}")
            continue
        dt = time.perf_counter() - t0
        rot, tra = pose_errors(m.registration.poses, scan.true_poses, c)
        fused = rms(surface_distances(m.fused.points, scan.truth_points, scan.truth_normals))
        assert m.mesh is not None
        mv = np.asarray(m.mesh.vertices)
        print(f"-- {mode}: {dt:.1f} s ({dt / len(views):.2f} s/view)")
        print(f"   pose error: rotation max {rot.max():.3f} mrad (mean {rot[1:].mean():.3f}), "
              f"translation at object centre max {tra.max():.1f} um (mean {tra[1:].mean():.1f})")
        print(f"   per-view residual RMS {np.round(m.registration.residual_rms_mm, 4).tolist()} mm")
        print(f"   pose 1-sigma rotation {np.round(m.registration.rotation_sigma_mrad, 4).tolist()} mrad")
        print(f"   pose error per view {np.round(rot, 3).tolist()} mrad")
        print(f"   fused RMS {fused:.4f} mm = {fused / np.mean(single):.2f} x single-view; "
              f"coverage {100 * coverage(m.fused.points, scan.truth_points, VOXEL):.2f} % "
              f"of the visible surface (within {VOXEL} mm); {len(m.fused.points)} fused points")
        print(f"   mesh {mesh_figures(m.mesh)}; mesh-to-truth RMS "
              f"{rms(surface_distances(mv, scan.truth_points, scan.truth_normals)):.4f} mm, "
              f"Hausdorff {hausdorff(mv, scan.truth_points):.3f} mm")
        if centres is not None:
            sp = multiview_sphere_spacing(m.fused.points, centres, radius,
                                          float(np.linalg.norm(centres[1] - centres[0])))
            print(f"   VDI/VDE 2634-3 sphere-spacing error SD = {1e3 * sp.error:.1f} um "
                  f"(measured {sp.distance:.4f} mm, true {np.linalg.norm(centres[1] - centres[0]):.4f} mm)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--bar-offset", type=float, default=0.0, help="first table angle of the sphere-bar (deg)")
    ap.add_argument("--scene", choices=("both", "sculpture", "sphere-bar"), default="both")
    a = ap.parse_args()
    p = presets.get("high-speed")
    if a.scene in ("both", "sculpture"):
        run("sculpture", sculpture_turntable(p, seed=a.seed), p, np.arange(-45.0, 46.0, 10.0), a.seed)
    if a.scene in ("both", "sphere-bar"):
        scene, centres, r = sphere_bar_scene(p)
        run("sphere-bar", scene, p, np.arange(0.0, 360.0, 30.0) + a.bar_offset, a.seed, centres, r)


if __name__ == "__main__":
    main()
