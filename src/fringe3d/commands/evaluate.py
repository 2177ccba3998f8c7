"""``fringe3d evaluate RESULT --sphere/--plane/--ball-bar [--truth DIR]``: accuracy figures."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from fringe3d.utils.console import console, make_table, print_json, set_quiet
from fringe3d.utils.jsonfile import write_json


# ----------------------------------------------------------------------------- inputs
def load_points(result: Path, frame: int = 0) -> tuple[np.ndarray, dict]:
    """Point map from a reconstruct output folder (points.npy or points.zarr), a .npy map, or a
    .ply cloud (unorganized, ``(N, 3)``). Returns ``(points, info)``."""
    result = Path(result)
    if not result.exists():
        raise FileNotFoundError(f"no reconstruction at {result} (expected a reconstruct output folder, .npy or .ply)")
    info = {}
    if result.is_dir():
        js = result / "reconstruct.json"
        if js.exists():
            from fringe3d.utils.jsonfile import read_json
            info = read_json(js, "reconstruction summary")
        if (result / "points.npy").exists():
            return _check_map(np.load(result / "points.npy"), result), info
        if (result / "points.zarr").exists():
            from fringe3d.io.store import PointMapStore
            st = PointMapStore.open_existing(result / "points.zarr")
            if not 0 <= frame < st.frames:
                raise ValueError(f"--frame {frame} is outside the store's 3D frames 0..{st.frames - 1}")
            if not st.is_done(frame):
                raise ValueError(f"3D frame {frame} of {result / 'points.zarr'} was never completed; rerun reconstruct")
            info["frame"] = frame
            return st.read(frame), info
        raise FileNotFoundError(f"{result} holds neither points.npy nor points.zarr; run fringe3d reconstruct first")
    if result.suffix == ".npy":
        return _check_map(np.load(result), result), info
    if result.suffix == ".ply":
        from fringe3d.io.pointcloud import read_ply
        return read_ply(result).points, info
    raise ValueError(f"{result}: expected a reconstruct output folder, a .npy point map or a .ply file")


def _check_map(P: np.ndarray, where) -> np.ndarray:
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"{where}: expected an (H, W, 3) point map, got shape {P.shape}")
    return P


def truth_frame_index(info: dict, frame: int) -> int:
    """Captured-frame index whose truth belongs to 3D frame ``frame`` of a sequence."""
    if info.get("mode") == "window":
        return frame * int(info.get("step") or 1)
    return frame * int(info.get("cycle_length") or 1)


def load_truth(folder: Path, info: dict, frame: int, shape):
    from fringe3d.sim.truth import Truth
    t = Truth.load(folder)
    if t.per_frame:
        t = t.frame(truth_frame_index(info, frame))
    if tuple(t.xyz.shape[:2]) != tuple(shape):
        raise ValueError(f"the truth in {folder} is {t.xyz.shape[1]}x{t.xyz.shape[0]} pixels but the point map is "
                         f"{shape[1]}x{shape[0]}; expected the truth of the capture that was reconstructed")
    return t


# ----------------------------------------------------------------------------- objects
def truth_objects(truth, kind: str) -> list[tuple[int, np.ndarray]]:
    """Object ids (with their truth masks) whose true surface is a ``kind`` ("sphere"/"plane"),
    largest first, judged by fitting the noise-free truth points."""
    from fringe3d.analyze.fits import fit_plane, fit_sphere
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
    from fringe3d.analyze.fits import fit_plane, fit_sphere
    from fringe3d.analyze.sections import segments
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
    from fringe3d.analyze.fits import fit_sphere
    from fringe3d.analyze.vdi import probing_errors
    fit = fit_sphere(points, mask)
    figs = probing_errors(points, mask, true_diameter, exclude).as_dict()
    figs["fit_rms"] = fit.rms
    if np.ndim(points) == 3:
        from fringe3d.analyze.sections import sphere_sections
        try:
            sec = sphere_sections(np.where(mask[..., None], points, np.nan) if mask is not None else points)
            figs["sections"] = {a: {"index": sec[a].index, "radius": sec[a].fit.radius, "rms": sec[a].fit.rms,
                                    "points": sec[a].fit.n_points} for a in ("row", "column")}
        except ValueError as e:
            figs["sections"] = {"error": str(e)}
    return figs


def register(app: typer.Typer) -> None:
    @app.command("evaluate")
    def evaluate_cmd(
        result: Path = typer.Argument(..., help="Reconstruct output folder (points.npy / points.zarr), .npy or .ply."),
        sphere: bool = typer.Option(False, "--sphere", help="Probing error form/size and cross sections of a sphere."),
        plane: bool = typer.Option(False, "--plane", help="Flatness error and plane RMS."),
        ball_bar: bool = typer.Option(False, "--ball-bar", help="Sphere-spacing error of two spheres."),
        truth: Path = typer.Option(None, "--truth", help="Simulated capture (or its truth/ folder) for ground truth."),
        diameter: float = typer.Option(None, "--diameter", help="Calibrated sphere diameter (mm); default from truth."),
        distance: float = typer.Option(None, "--distance", help="Calibrated ball-bar length (mm); default from truth."),
        frame: int = typer.Option(0, "--frame", help="3D frame of a sequence store."),
        exclude: float = typer.Option(0.0, "--exclude", help="Share of worst points to drop (<= 0.003, VDI/VDE 2634-2)."),
        json_: bool = typer.Option(False, "--json", help="Print one JSON object."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No tables."),
    ) -> None:
        """Accuracy figures of a reconstruction: fits, VDI/VDE 2634-2-style errors, error vs truth.

        Writes RESULT/evaluate.json (folders only). With --truth the objects are picked from the
        simulator's object ids and the true sizes come from the noise-free truth surface.

        Example: fringe3d evaluate sphere-3d --sphere --truth sphere-capture --json
        """
        from fringe3d.analyze.fits import fit_plane, fit_sphere
        from fringe3d.analyze.vdi import flatness, sphere_spacing

        set_quiet(quiet or json_)
        if sum([sphere, plane, ball_bar]) > 1:
            raise ValueError("choose one of --sphere, --plane, --ball-bar")
        points, info = load_points(result, frame)
        organized = points.ndim == 3
        out: dict = {"result": str(result), "frame": frame}
        t = None
        if truth is not None:
            if not organized:
                raise ValueError("--truth needs an organized point map (points.npy / points.zarr), not a PLY cloud")
            t = load_truth(truth, info, frame, points.shape[:2])
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
                    from fringe3d.io.images import write_image
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
        if result.is_dir():
            write_json(result / "evaluate.json", out)
        if json_:
            print_json(out)
            return
        if quiet:
            return
        rows = []
        for sect in ("truth", "sphere", "plane", "ball_bar"):
            for k, v in out.get(sect, {}).items():
                if not isinstance(v, (dict, list, tuple)):
                    rows.append([f"{sect}.{k}", v])
        console.print(make_table(f"evaluation of {result}", ["figure", "value (mm)"], rows))
