"""Accuracy figures of a reconstruction (what ``fringe3d evaluate`` reports): point maps from a
reconstruct output, the objects to judge (from the simulator's object ids or by shape), and
VDI/VDE 2634-2-style figures (probing errors, flatness, sphere spacing) plus the 3D error
against ground truth.

Objects are classified with closed-form fits (:mod:`fringe3d.analyze.classify`); only the
model chosen is refined by geometric least squares, once, under the outlier rule of
:mod:`fringe3d.analyze.outliers`."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fringe3d.io.images import write_image
from fringe3d.io.pointcloud import read_ply
from fringe3d.io.store import PointMapStore
from fringe3d.utils.jsonfile import read_json
from fringe3d.io.arrays import load_array
from fringe3d.utils.output_folder import check_complete

from fringe3d.utils.console import progress_bar

from .classify import guess_shape, is_exact
from .fits import fit_plane, fit_sphere
from .outliers import fit_with_outliers, form_warning
from .sections import segments, sphere_sections
from .truth_points import TruthPoints, true_sphere, truth_point_errors
from .vdi import SpacingFigures, flatness, probing_errors


# ----------------------------------------------------------------------------- inputs
def load_points(result: Path, frame: int = 0) -> tuple[np.ndarray, dict]:
    """Point map from a reconstruct output folder (points.npy or points.zarr), a .npy map, or a
    .ply cloud (unorganized, ``(N, 3)``).

    Parameters
    ----------
    result : Path
        A reconstruct output folder (``points.npy`` or ``points.zarr``), a ``fringe3d merge``
        folder (its ``fused.ply``, unorganized), a ``.npy`` point map or a ``.ply`` file.
    frame : int
        3D frame to read from a ``points.zarr`` store (ignored otherwise).

    Returns
    -------
    points : (H, W, 3) or (N, 3) ndarray
        Points, mm (NaN = invalid); an infinite coordinate raises ValueError.
    info : dict
        The folder's ``reconstruct.json`` summary (empty without one), with ``"frame"`` for a
        store.
    """
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
                raise ValueError(f"`frame` {frame} is outside the store's 3D frames 0..{st.frames - 1}")
            if not st.is_done(frame):
                raise ValueError(f"3D frame {frame} of {result / 'points.zarr'} was never completed; rerun reconstruct")
            info["frame"] = frame
            return check_finite_points(st.read(frame), result / "points.zarr"), info
        if (result / "merge.json").exists() and (result / "fused.ply").exists():  # a fringe3d merge folder
            return check_finite_points(read_ply(result / "fused.ply").points, result / "fused.ply"), info
        raise FileNotFoundError(f"{result} holds neither points.npy nor points.zarr; run fringe3d reconstruct first")
    if result.suffix == ".npy":
        return check_point_map(load_array(result, "point map"), result), info
    if result.suffix == ".ply":
        return check_finite_points(read_ply(result).points, result), info
    raise ValueError(f"{result}: expected a reconstruct output folder, a .npy point map or a .ply file")


def check_point_map(P: np.ndarray, where) -> np.ndarray:
    """``P`` unless it is not an (H, W, 3) point map or holds an infinite coordinate (ValueError)."""
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"{where}: expected an (H, W, 3) point map, got shape {P.shape}")
    return check_finite_points(P, where)


def check_finite_points(P: np.ndarray, where) -> np.ndarray:
    """``P`` (..., 3) mm unless a point holds +-inf: fringe3d marks an invalid point with NaN, so an
    infinite coordinate is a damaged or foreign file, refused rather than silently dropped."""
    bad = int(np.count_nonzero(np.isinf(np.asarray(P, dtype=np.float64)).any(axis=-1)))
    if bad:
        raise ValueError(f"{where}: {bad} point(s) hold an infinite coordinate; expected finite mm or NaN (invalid) "
                         "in every coordinate")
    return P


def truth_frame_index(info: dict, frame: int) -> int:
    """Captured-frame index whose truth belongs to 3D frame ``frame`` of a sequence."""
    if info.get("mode") == "window":
        return frame * int(info.get("step") or 1)
    return frame * int(info.get("cycle_length") or 1)


# ----------------------------------------------------------------------------- objects
def truth_objects(truth, kind: str) -> list[tuple[int, np.ndarray]]:
    """Object ids (with their truth masks) whose true surface is a ``kind`` ("sphere"/"plane"),
    largest first, judged by closed-form fits of the noise-free truth points
    (:func:`fringe3d.analyze.classify.is_exact`)."""
    out = []
    ids = np.unique(truth.object_id[truth.mask])
    with progress_bar(f"finding {kind}s in the truth", len(ids)) as advance:
        for oid in ids:
            m = truth.mask & (truth.object_id == oid)
            if m.sum() >= 20 and is_exact(truth.xyz[m], kind):
                out.append((int(oid), m))
            advance()
    return sorted(out, key=lambda t: -int(t[1].sum()))


def measured_objects(points: np.ndarray, kind: str) -> list[np.ndarray]:
    """Masks of smooth pieces of the map that look like ``kind`` (no truth available), largest
    first. A piece is sphere-like when an algebraic sphere of radius below twice the piece's
    extent fits it with less than half the plane fit's RMS; every other piece is plane-like
    (:func:`fringe3d.analyze.classify.guess_shape`)."""
    labels = segments(points)
    n = int(labels.max()) + 1
    cands = []
    flat = labels.ravel()
    order = np.argsort(flat, kind="stable")
    bounds = np.searchsorted(flat[order], np.arange(n + 1))
    xyz = points.reshape(-1, 3)
    with progress_bar(f"classifying {n} surface pieces", n) as advance:
        for k in range(n):
            idx = order[bounds[k]:bounds[k + 1]]
            if len(idx) >= 4 and guess_shape(xyz[idx]).kind == kind:
                m = np.zeros(flat.size, bool)
                m[idx] = True
                cands.append(m.reshape(labels.shape))
            advance()
    return cands


# ----------------------------------------------------------------------------- figures
def truth_errors(points: np.ndarray, truth) -> dict:
    """3D error against the simulator's truth over pixels valid in both (mm).

    Parameters
    ----------
    points : (H, W, 3) ndarray
        Organized point map, mm (NaN = invalid).
    truth : Truth-like
        Ground truth with ``xyz (H, W, 3)`` mm and ``mask (H, W)``.

    Returns
    -------
    dict
        ``rms_mm``, ``mean_mm``, ``median_mm``, ``max_mm`` of the point-to-truth distance, the
        ``coverage`` (share of the truth's pixels measured), ``share_over_1mm`` and ``points``.
    """
    ok = np.isfinite(points[..., 0]) & truth.mask
    if not ok.any():
        raise ValueError("no pixel is valid in both the reconstruction and the truth; is this the right truth?")
    e = np.linalg.norm(points[ok] - truth.xyz[ok], axis=-1)
    return {"rms_mm": float(np.sqrt(np.mean(e ** 2))), "mean_mm": float(e.mean()), "median_mm": float(np.median(e)),
            "max_mm": float(e.max()), "coverage": float(ok.sum() / max(int(truth.mask.sum()), 1)),
            "share_over_1mm": float(np.mean(e > 1.0)), "points": int(ok.sum())}


def _warned(figs: dict, what: str, form: float, rms: float) -> dict:
    msg = form_warning(what, form, rms)
    if msg:
        figs.setdefault("warnings", []).append(msg)
    return figs


def sphere_figures(points, mask, true_diameter, exclude: float | None = None) -> dict:
    """Probing errors (VDI/VDE 2634-2), fit RMS and, for organized maps, the row / column
    cross sections of a sphere (mm). One geometric sphere fit under the outlier rule
    ``exclude`` (None: robust, a share: VDI/VDE 2634-2; :mod:`fringe3d.analyze.outliers`)."""
    figs, _ = sphere_figures_and_fit(points, mask, true_diameter, exclude)
    return figs


def sphere_figures_and_fit(points, mask, true_diameter, exclude: float | None = None):
    """:func:`sphere_figures` and the :class:`~fringe3d.analyze.fits.SphereFit` behind them."""
    fit, rule = fit_with_outliers(fit_sphere, points, mask, exclude)
    figs = probing_errors(points, mask, true_diameter, fit=fit).as_dict()
    figs["fit_rms"] = fit.rms
    figs["outliers"] = rule
    _warned(figs, "sphere P_F", figs["form"], fit.rms)
    if np.ndim(points) == 3:
        try:
            used = np.isfinite(fit.residual_map)
            sec = sphere_sections(np.where(used[..., None], points, np.nan), sphere=fit)
            figs["sections"] = {a: {"index": sec[a].index, "radius": sec[a].fit.radius, "rms": sec[a].fit.rms,
                                    "points": sec[a].fit.n_points} for a in ("row", "column")}
        except ValueError as e:
            figs["sections"] = {"error": str(e)}
    return figs, fit


def _write_map(result, name: str, values: np.ndarray) -> str | None:
    """Write an (H, W) float32 map (mm, NaN = no value) into a reconstruct output folder; its name."""
    if not (isinstance(result, Path) and result.is_dir()):
        return None
    return write_image(result / name, np.asarray(values, np.float32), name.removesuffix(".tif"), "mm").name


def plane_figures(points, mask, exclude: float | None = None):
    """Flatness ``F`` (VDI/VDE 2634-2) and RMS of one plane fit under the outlier rule; returns
    ``(figures, fit)``."""
    fit, rule = fit_with_outliers(fit_plane, points, mask, exclude)
    figs = flatness(points, mask, fit=fit).as_dict()
    figs["outliers"] = rule
    return _warned(figs, "flatness F", figs["flatness"], fit.rms), fit


def spacing_figures(points, mask_a, mask_b, true_distance, true_diameter, exclude: float | None = None) -> dict:
    """Sphere-spacing error ``SD`` of a ball bar: both spheres fitted (free radius) under the
    outlier rule, ``SD = |c_a - c_b| - L``."""
    figs, centres, rules = [], [], []
    for name, m in (("first", mask_a), ("second", mask_b)):
        try:
            fit, rule = fit_with_outliers(fit_sphere, points, m, exclude)
        except ValueError as e:
            raise ValueError(f"ball bar, {name} sphere: {e}") from None
        figs.append(probing_errors(points, m, true_diameter, fit=fit))
        centres.append(fit.center)
        rules.append(rule)
    dist = float(np.linalg.norm(centres[0] - centres[1]))
    err = None if true_distance is None else dist - float(true_distance)
    out = SpacingFigures(err, dist, tuple(figs)).as_dict()
    out["outliers"] = rules
    for k, f in enumerate(figs):
        _warned(out, f"ball-bar sphere {k} P_F", f.form, f.rms)
    return out


def cloud_ball_bar(points, centres, radius: float, true_distance: float | None = None,
                   true_diameter: float | None = None, exclude: float | None = None,
                   margin: float | None = None) -> dict:
    """VDI/VDE 2634-3 sphere spacing of a ball bar in an unorganised (merged multi-view) cloud.

    Parameters
    ----------
    points : (N, 3) float
        The cloud, mm.
    centres : (2, 3) float
        Nominal sphere centres, mm (true ones, or :func:`fringe3d.analyze.ball_bar.find_spheres`).
    radius : float
        Nominal sphere radius, mm.
    true_distance, true_diameter : float, optional
        Calibrated centre distance and sphere diameter, mm.
    exclude : float or None
        The outlier rule (:func:`spacing_figures`).
    margin : float, optional
        Half-width (mm) of the shell about each nominal sphere whose points are fitted; default
        5 % of the radius (the bar where it joins a sphere stays outside).

    Returns
    -------
    dict
        :func:`spacing_figures` (``error`` = SD, mm; both spheres' form ``P_F``) plus
        ``error_um``, ``nominal_centres``, ``shell_margin`` and ``true_distance``.
    """
    from .ball_bar import shell_masks

    C = np.asarray(centres, float)
    if C.shape != (2, 3):
        raise ValueError(f"the nominal centres must be two 3D points (2, 3), got shape {C.shape}")
    m = 0.05 * radius if margin is None else float(margin)
    P = np.asarray(points, float).reshape(-1, 3)
    ma, mb = shell_masks(P, C, radius, m)
    figs = spacing_figures(P, ma, mb, true_distance, true_diameter, exclude)
    err = figs.get("error")
    return {"method": "merged cloud, VDI/VDE 2634-3", "true_distance": true_distance, **figs,
            "error_um": None if err is None else 1e3 * err, "nominal_centres": C.tolist(), "shell_margin": m}


def evaluate_points(points: np.ndarray, truth=None, *, sphere: bool = False, plane: bool = False,
                    ball_bar: bool = False, diameter: float | None = None, distance: float | None = None,
                    exclude: float | None = None, result: Path | None = None) -> dict:
    """Accuracy figures of a point map (what ``fringe3d evaluate`` reports), in mm.

    Parameters
    ----------
    points : (H, W, 3) or (N, 3) float
        Organized point map (NaN invalid) or an unorganized cloud.
    truth : Truth-like or TruthPoints, optional
        ``xyz (H, W, 3)``, ``mask (H, W)`` and ``object_id (H, W)`` of the simulator's ground
        truth (objects are then picked by id and true sizes come from the truth surface), or
        :class:`~fringe3d.analyze.truth_points.TruthPoints` (true surface points ``(N, 3)``:
        errors are point-to-surface distances, objects are found by shape and true sphere
        sizes come from the true points nearest the measured sphere).
    sphere, plane, ball_bar : bool
        Which figures: probing errors (VDI/VDE 2634-2), flatness, sphere spacing.
    diameter, distance : float, optional
        Calibrated sphere diameter / ball-bar length (default from the truth).
    exclude : float or None
        None: robust outlier rule (default); a share <= 0.003: drop that share of the worst
        points (VDI/VDE 2634-2). See :mod:`fringe3d.analyze.outliers`.
    result : Path, optional
        A reconstruct output folder: the plane's residual map is written there.

    Returns
    -------
    ``{"truth": ..., "sphere": ..., "plane": ..., "ball_bar": ...}`` (the sections asked for).
    """
    organized = points.ndim == 3
    out: dict = {}
    points_truth = isinstance(truth, TruthPoints)
    t = None if points_truth else truth
    if points_truth:
        out["truth"] = truth_point_errors(points, truth)
    elif t is not None:
        if not organized:
            raise ValueError("`truth` needs an organized point map (points.npy / points.zarr), not a PLY cloud")
        out["truth"] = truth_errors(points, t)
        ok = np.isfinite(points[..., 0]) & t.mask
        d = np.where(ok[..., None], points - t.xyz, 0.0)  # signed by depth: + farther than the truth
        err = np.where(ok, np.copysign(np.linalg.norm(d, axis=-1), d[..., 2]), np.nan)
        if name := _write_map(result, "truth_error.tif", err):
            out["truth"]["error_map"] = name
    valid = np.all(np.isfinite(points), axis=-1)

    def objects(kind, n):
        if t is not None:
            objs = truth_objects(t, kind)
            if len(objs) < n:
                raise ValueError(f"the truth holds {len(objs)} {kind}(s); --{kind.replace('_', '-')} needs {n}")
            return [(m, oid) for oid, m in objs[:n]]
        if not organized:
            if n > 1:
                raise ValueError("`ball_bar` needs an organized point map to separate the spheres")
            return [(None, None)]
        objs = measured_objects(points, kind)
        if len(objs) < n:
            raise ValueError(f"found {len(objs)} {kind}-like surface(s) in the point map, need {n} "
                             "(pass `truth` to pick objects from the simulator's ids)")
        return [(m, None) for m in objs[:n]]

    def true_fit(oid, m):
        if t is not None:
            return fit_sphere(t.xyz, t.mask & (t.object_id == oid))
        if points_truth:
            return true_sphere(truth, points[m] if m is not None else points)
        return None

    if sphere:
        (m, oid), = objects("sphere", 1)
        d_true = diameter
        if d_true is None:
            tf = true_fit(oid, m)
            d_true = None if tf is None else tf.diameter
        mm = None if m is None else (m & valid)
        figs, fit = sphere_figures_and_fit(points, mm, d_true, exclude)
        out["sphere"] = {"object_id": oid, "true_diameter": d_true, **figs}
        if organized and (name := _write_map(result, "sphere_residuals.tif", fit.residual_map)):
            out["sphere"]["residual_map"] = name
    if plane:
        (m, oid), = objects("plane", 1)
        mm = None if m is None else (m & valid)
        fig, fit = plane_figures(points, mm, exclude)
        out["plane"] = {"object_id": oid, **fig}
        if organized:
            # every point of the piece, excluded ones included, against the plane fitted without them
            res = np.where(mm if mm is not None else valid, fit.distance(points), np.nan)
            if name := _write_map(result, "plane_residuals.tif", res):
                out["plane"]["residual_map"] = name
    if ball_bar:
        (ma, oa), (mb, ob) = objects("sphere", 2)
        L, d_true = distance, diameter
        fa, fb = true_fit(oa, ma), true_fit(ob, mb)
        if fa is not None and fb is not None:
            L = L if L is not None else float(np.linalg.norm(fa.center - fb.center))
            same = abs(fa.radius - fb.radius) <= (1e-3 if points_truth else 1e-6) * max(fa.radius, 1.0)
            d_true = d_true if d_true is not None or not same else fa.diameter
        out["ball_bar"] = {"object_ids": [oa, ob], "true_distance": L,
                           **spacing_figures(points, ma & valid, mb & valid, L, d_true, exclude)}
    return out
