"""Accuracy figures of a reconstruction (what ``fringe3d evaluate`` reports): point maps from a
reconstruct output, the objects to judge (from the simulator's object ids or by shape), and
VDI/VDE 2634-2-style figures (probing errors, flatness, sphere spacing) plus the 3D error
against ground truth."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fringe3d.io.images import write_image
from fringe3d.io.pointcloud import read_ply
from fringe3d.io.store import PointMapStore
from fringe3d.utils.jsonfile import read_json
from fringe3d.io.arrays import load_array
from fringe3d.utils.output_folder import check_complete

from .fits import fit_plane, fit_sphere
from .sections import segments, sphere_sections
from .vdi import flatness, probing_errors, sphere_spacing


# ----------------------------------------------------------------------------- inputs
def load_points(result: Path, frame: int = 0) -> tuple[np.ndarray, dict]:
    """Point map from a reconstruct output folder (points.npy or points.zarr), a .npy map, or a
    .ply cloud (unorganized, ``(N, 3)``). Returns ``(points, info)``."""
    result = Path(result)
    if not result.exists():
        raise FileNotFoundError(f"no reconstruction at {result} (expected a reconstruct output folder, .npy or .ply)")
    info = {}
    if result.is_dir():
        check_complete(result, "reconstruction")
        js = result / "reconstruct.json"
        if js.exists():
            info = read_json(js, "reconstruction summary")
        if (result / "points.npy").exists():
            return check_point_map(load_array(result / "points.npy", "point map"), result), info
        if (result / "points.zarr").exists():
            st = PointMapStore.open_existing(result / "points.zarr")
            if not 0 <= frame < st.frames:
                raise ValueError(f"--frame {frame} is outside the store's 3D frames 0..{st.frames - 1}")
            if not st.is_done(frame):
                raise ValueError(f"3D frame {frame} of {result / 'points.zarr'} was never completed; rerun reconstruct")
            info["frame"] = frame
            return st.read(frame), info
        raise FileNotFoundError(f"{result} holds neither points.npy nor points.zarr; run fringe3d reconstruct first")
    if result.suffix == ".npy":
        return check_point_map(load_array(result, "point map"), result), info
    if result.suffix == ".ply":
        return read_ply(result).points, info
    raise ValueError(f"{result}: expected a reconstruct output folder, a .npy point map or a .ply file")


def check_point_map(P: np.ndarray, where) -> np.ndarray:
    """``P`` unless it is not an (H, W, 3) point map (ValueError)."""
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"{where}: expected an (H, W, 3) point map, got shape {P.shape}")
    return P


def truth_frame_index(info: dict, frame: int) -> int:
    """Captured-frame index whose truth belongs to 3D frame ``frame`` of a sequence."""
    if info.get("mode") == "window":
        return frame * int(info.get("step") or 1)
    return frame * int(info.get("cycle_length") or 1)


# ----------------------------------------------------------------------------- objects
def truth_objects(truth, kind: str) -> list[tuple[int, np.ndarray]]:
    """Object ids (with their truth masks) whose true surface is a ``kind`` ("sphere"/"plane"),
    largest first, judged by fitting the noise-free truth points."""
    out = []
    for oid in np.unique(truth.object_id[truth.mask]):
        m = truth.mask & (truth.object_id == oid)
        if m.sum() < 20:
            continue
        try:
            f = fit_sphere(truth.xyz, m) if kind == "sphere" else fit_plane(truth.xyz, m)
        except ValueError:
            continue
        scale = f.radius if kind == "sphere" else 1.0
        if f.rms < 1e-4 * max(scale, 1.0) and (kind != "sphere" or f.radius < 1e5):
            out.append((int(oid), m))
    return sorted(out, key=lambda t: -int(t[1].sum()))


def measured_objects(points: np.ndarray, kind: str) -> list[np.ndarray]:
    """Masks of smooth pieces of the map that look like ``kind`` (no truth available), largest
    first. A piece is sphere-like when a sphere of radius below twice the piece's extent fits
    it with less than half the plane fit's RMS; every other piece is plane-like."""
    labels = segments(points)
    cands = []
    for k in range(int(labels.max()) + 1):
        m = labels == k
        try:
            pl = fit_plane(points, m)
            sp = fit_sphere(points, m)
        except ValueError:
            continue
        xyz = points[m]
        extent = float(np.linalg.norm(np.nanmax(xyz, axis=0) - np.nanmin(xyz, axis=0)))
        sphere_like = sp.radius < 2 * extent and sp.rms < 0.5 * pl.rms
        if sphere_like == (kind == "sphere"):
            cands.append(m)
    return cands


# ----------------------------------------------------------------------------- figures
def truth_errors(points: np.ndarray, truth) -> dict:
    """3D error against the simulator's truth over pixels valid in both (mm)."""
    ok = np.isfinite(points[..., 0]) & truth.mask
    if not ok.any():
        raise ValueError("no pixel is valid in both the reconstruction and the truth; is this the right truth?")
    e = np.linalg.norm(points[ok] - truth.xyz[ok], axis=-1)
    return {"rms_mm": float(np.sqrt(np.mean(e ** 2))), "mean_mm": float(e.mean()), "median_mm": float(np.median(e)),
            "max_mm": float(e.max()), "coverage": float(ok.sum() / max(int(truth.mask.sum()), 1)),
            "share_over_1mm": float(np.mean(e > 1.0)), "points": int(ok.sum())}


def sphere_figures(points, mask, true_diameter, exclude) -> dict:
    """Probing errors (VDI/VDE 2634-2), fit RMS and, for organized maps, the row / column
    cross sections of a sphere (mm)."""
    fit = fit_sphere(points, mask)
    figs = probing_errors(points, mask, true_diameter, exclude).as_dict()
    figs["fit_rms"] = fit.rms
    if np.ndim(points) == 3:
        try:
            sec = sphere_sections(np.where(mask[..., None], points, np.nan) if mask is not None else points)
            figs["sections"] = {a: {"index": sec[a].index, "radius": sec[a].fit.radius, "rms": sec[a].fit.rms,
                                    "points": sec[a].fit.n_points} for a in ("row", "column")}
        except ValueError as e:
            figs["sections"] = {"error": str(e)}
    return figs


def evaluate_points(points: np.ndarray, truth=None, *, sphere: bool = False, plane: bool = False,
                    ball_bar: bool = False, diameter: float | None = None, distance: float | None = None,
                    exclude: float = 0.0, result: Path | None = None) -> dict:
    """Accuracy figures of a point map (what ``fringe3d evaluate`` reports), in mm.

    Parameters
    ----------
    points : (H, W, 3) or (N, 3) float
        Organized point map (NaN invalid) or an unorganized cloud.
    truth : Truth-like, optional
        ``xyz (H, W, 3)``, ``mask (H, W)`` and ``object_id (H, W)`` of the simulator's ground
        truth; objects are then picked by id and true sizes come from the truth surface.
    sphere, plane, ball_bar : bool
        Which figures: probing errors (VDI/VDE 2634-2), flatness, sphere spacing.
    diameter, distance : float, optional
        Calibrated sphere diameter / ball-bar length (default from the truth).
    exclude : float
        Share of worst points to drop (<= 0.003, VDI/VDE 2634-2).
    result : Path, optional
        A reconstruct output folder: the plane's residual map is written there.

    Returns
    -------
    ``{"truth": ..., "sphere": ..., "plane": ..., "ball_bar": ...}`` (the sections asked for).
    """
    organized = points.ndim == 3
    out: dict = {}
    t = truth
    if t is not None:
        if not organized:
            raise ValueError("--truth needs an organized point map (points.npy / points.zarr), not a PLY cloud")
        out["truth"] = truth_errors(points, t)
    valid = np.all(np.isfinite(points), axis=-1)

    def objects(kind, n):
        if t is not None:
            objs = truth_objects(t, kind)
            if len(objs) < n:
                raise ValueError(f"the truth holds {len(objs)} {kind}(s); --{kind.replace('_', '-')} needs {n}")
            return [(m, oid) for oid, m in objs[:n]]
        if not organized:
            if n > 1:
                raise ValueError("--ball-bar needs an organized point map to separate the spheres")
            return [(None, None)]
        objs = measured_objects(points, kind)
        if len(objs) < n:
            raise ValueError(f"found {len(objs)} {kind}-like surface(s) in the point map, need {n} "
                             "(pass --truth to pick objects from the simulator's ids)")
        return [(m, None) for m in objs[:n]]

    if sphere:
        (m, oid), = objects("sphere", 1)
        d_true = diameter
        if d_true is None and t is not None:
            d_true = fit_sphere(t.xyz, t.mask & (t.object_id == oid)).diameter
        mm = None if m is None else (m & valid)
        out["sphere"] = {"object_id": oid, "true_diameter": d_true,
                         **sphere_figures(points, mm, d_true, exclude)}
    if plane:
        (m, oid), = objects("plane", 1)
        mm = None if m is None else (m & valid)
        fig = flatness(points, mm, exclude).as_dict()
        out["plane"] = {"object_id": oid, **fig}
        if organized:
            fit = fit_plane(points, mm)
            if isinstance(result, Path) and result.is_dir():
                out["plane"]["residual_map"] = str(write_image(result / "plane_residuals.tif", fit.residual_map))
    if ball_bar:
        (ma, oa), (mb, ob) = objects("sphere", 2)
        L, d_true = distance, diameter
        if t is not None:
            fa = fit_sphere(t.xyz, t.mask & (t.object_id == oa))
            fb = fit_sphere(t.xyz, t.mask & (t.object_id == ob))
            L = L if L is not None else float(np.linalg.norm(fa.center - fb.center))
            d_true = d_true if d_true is not None or abs(fa.radius - fb.radius) > 1e-6 else fa.diameter
        out["ball_bar"] = {"object_ids": [oa, ob], "true_distance": L,
                           **sphere_spacing(points, ma & valid, mb & valid, L, d_true, exclude).as_dict()}
    return out
