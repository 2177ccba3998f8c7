"""``fringe3d demo``: the whole measurement chain on the built-in virtual rig.

render a calibration session → calibrate through the phase domain → render a measurement
scene (a freeform sculpture, a sphere and an isolated second sphere forming a ball bar) →
decode (three-frequency heterodyne) → triangulate with the *calibrated* rig → evaluate
against the simulator's ground truth → write calibration JSON, PLY point clouds, PNG
figures, ``summary.json`` and a self-contained ``report.html``.
"""
from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.ndimage import binary_erosion

from fringe3d.analyze.vdi import probing_errors, sphere_spacing
from fringe3d.calibrate.gates import Gate, failure_message
from fringe3d.calibrate.plots import residual_plot
from fringe3d.calibrate.session import calibrate_observations, observe_session
from fringe3d.decode import decode
from fringe3d.io.ply_standard import write_measurement_ply
from fringe3d.patterns import sets
from fringe3d.reconstruct.triangulate import triangulate
from fringe3d.report import write_report
from fringe3d.report.results import save_summary
from fringe3d.sim import presets, render
from fringe3d.sim.calibration_session import SessionOptics, simulate_session
from fringe3d.utils.warning_types import CalibrationWarning
from fringe3d.sim.catalog import facing_rotation, preset_frame
from fringe3d.sim import Scene, Sphere
from fringe3d.sim.sculpture import sculpture
from fringe3d.utils.atomic import atomic_path

#: Named demo profiles: (preset, board poses, camera scale).
PROFILES = {
    "default": ("macro", 10, 1.0),
    "tiny": ("tiny", 6, 1.0),
}


#: Share of sphere points VDI/VDE 2634-2 allows to exclude as outliers (0.3 %): the few
#: silhouette pixels whose fringe order is wrong.
VDI_EXCLUDE = 0.003


@dataclass
class Stages:
    """Wall-clock seconds per stage, in order; ``announce(text)`` (if given) is told each stage's start."""

    rows: list
    announce: Callable[[str], None] | None = None

    @contextmanager
    def time(self, name: str):
        if self.announce is not None:
            self.announce(f"[bold]{name}[/] …")
        t0 = time.perf_counter()
        yield
        self.rows.append({"name": name, "seconds": round(time.perf_counter() - t0, 2)})


def measurement_scene(preset, seed: int = 0):
    """Sculpture on the left, two isolated spheres (a ball bar) on the right of the volume."""
    c, size, view, down = preset_frame(preset)
    right = np.cross(down, view)
    relief = 0.12 * size[2]
    sc = sculpture(center=c - right * (0.2 * size[0]) + view * (0.5 * relief),
                   size=(0.45 * size[0], 0.7 * size[1]), relief=relief, seed=seed, R=facing_rotation(view, down))
    r = 0.14 * min(size[0], size[1])
    a = Sphere(c + right * (0.25 * size[0]) - down * (0.22 * size[1]), r, albedo=0.85)
    b = Sphere(c + right * (0.28 * size[0]) + down * (0.22 * size[1]) + view * (0.1 * size[2]), r, albedo=0.85)
    return Scene([sc, a, b], name="demo"), {"sculpture": 0, "sphere": 1, "sphere_b": 2}, r


def _calibration_figures(cal, true_rig) -> dict:
    """Calibration residuals plus the calibrated-vs-true parameter errors."""
    est, tru = cal.rig, true_rig
    fx = lambda d: float(d.K[0, 0])  # noqa: E731
    rot = np.degrees(np.arccos(np.clip((np.trace(est.projector.R @ tru.projector.R.T) - 1) / 2, -1, 1)))
    return {
        "camera reprojection RMS (px)": cal.rms["camera_px"],
        "projector reprojection RMS (px)": cal.rms["projector_px"],
        "camera focal length error (%)": 100 * (fx(est.camera) - fx(tru.camera)) / fx(tru.camera),
        "projector focal length error (%)": 100 * (fx(est.projector) - fx(tru.projector)) / fx(tru.projector),
        "projector position error (mm)": float(np.linalg.norm(est.projector.center - tru.projector.center)),
        "projector rotation error (deg)": float(rot),
        "poses used": len(cal.poses),
    }


def _evaluate(points, truth, ids: dict, radius: float) -> tuple[dict, list]:
    """Sphere fits, ball-bar spacing and sculpture error against the truth (mm)."""
    valid = np.isfinite(points).all(axis=-1)
    masks = {k: binary_erosion(truth.object_id == i, iterations=2) & valid & truth.mask for k, i in ids.items()}
    diff = points - truth.xyz
    err = np.linalg.norm(diff, axis=-1)
    metrics, accuracy = {}, []
    sph = probing_errors(points, masks["sphere"], true_diameter=2 * radius, exclude=VDI_EXCLUDE)
    metrics["sphere"] = {"sphere-fit RMS (mm)": sph.rms, "probing error form P_F (mm)": sph.form,
                         "probing error size P_S (mm)": sph.size, "points": sph.n_points}
    spacing_true = float(np.linalg.norm(truth.meta["centers"][1] - truth.meta["centers"][0]))
    bar = sphere_spacing(points, masks["sphere"], masks["sphere_b"], true_distance=spacing_true,
                         exclude=VDI_EXCLUDE)
    sculpt = err[masks["sculpture"]]
    metrics["sculpture"] = {"3D error RMS vs truth (mm)": float(np.sqrt(np.mean(sculpt**2))),
                            "3D error 95th percentile (mm)": float(np.percentile(sculpt, 95)),
                            "points": int(sculpt.size)}
    metrics["ball bar"] = {"sphere spacing error (mm)": bar.error, "true spacing (mm)": spacing_true}
    accuracy += [
        {"quantity": "sphere-fit RMS", "value": sph.rms, "unit": "mm", "dissertation": "0.071 / 0.077 / 0.073 (ch. 2)"},
        {"quantity": "probing error form P_F", "value": sph.form, "unit": "mm"},
        {"quantity": "probing error size P_S", "value": sph.size, "unit": "mm"},
        {"quantity": "sphere spacing error", "value": bar.error, "unit": "mm"},
        {"quantity": "sculpture 3D error RMS", "value": metrics["sculpture"]["3D error RMS vs truth (mm)"],
         "unit": "mm"},
    ]
    return metrics, accuracy, np.copysign(err, diff[..., 2]), masks  # signed: + farther than the truth


def run_demo(out: str | Path, profile: str = "default", seed: int = 0,
             sequences: Callable[[int], dict] | None = None, announce: Callable[[str], None] | None = None) -> dict:
    """Run the chain and write the results folder ``out``; returns the summary dict.

    ``sequences(seed)``, if given, runs further jobs (``fringe3d demo --full`` passes
    :func:`fringe3d.experiments.run_sequences`) whose results join the summary and report as
    ``"sequences"`` (``{name: {"goals", "tables", "seconds"}}``). ``announce(text)`` is told
    the start of each stage (the CLI prints it).
    """
    if profile not in PROFILES:
        raise ValueError(f"unknown demo profile {profile!r}; expected one of {', '.join(PROFILES)}")
    preset_name, n_poses, scale = PROFILES[profile]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    st = Stages([], announce)
    preset = presets.get(preset_name)

    with st.time("render calibration session"):
        sess = simulate_session(preset, n_poses=n_poses, seed=seed, optics=SessionOptics(camera_scale=scale))
    with st.time("calibrate"):
        obs, inf = observe_session(sess.poses, sess.board, progress=True)
        cal, res = calibrate_observations(obs, inf, sess.board)
        if not cal.acceptance["passed"]:
            warnings.warn(failure_message([Gate(**g) for g in cal.acceptance["gates"]]), CalibrationWarning,
                          stacklevel=2)
        cal.save(out / "calibration.json")
        residual_plot(out / "calibration_residuals.png", res.camera.residuals, res.projector.residuals,
                      res.pose_names, title="calibration reprojection residuals",
                      camera_points=getattr(res, "camera_points", None),
                      image_size=(sess.rig.camera.width, sess.rig.camera.height))
    with st.time("render measurement scene"):
        scene, ids, radius = measurement_scene(preset, seed)
        ps = sets.three_frequency("v", width=sess.rig.projector.width, height=sess.rig.projector.height)
        frames, truth = render(scene, sess.rig, ps, preset.settings.replace(seed=seed + 7))
        truth.meta["centers"] = [scene.objects[1].center, scene.objects[2].center]
    with st.time("decode + reconstruct"):
        dec = decode(frames, ps)
        points = triangulate(cal.rig, up=dec.projector_coordinate("v"), mask=dec.mask["v"])
    with st.time("evaluate"):
        metrics, accuracy, err, masks = _evaluate(points, truth, ids, radius)
    with st.time("write outputs"):
        measurements = _write_outputs(out, points, err, masks, metrics, dec.texture)
    summary = {
        "title": "fringe3d demo — virtual rig measurement",
        "subtitle": f"preset {preset.name} ({preset.description}); seed {seed}; {len(cal.poses)} board poses; "
                    "calibrated through the phase domain, measured with the 18/21/144 three-frequency set",
        "calibration": {"file": "calibration.json", "figures": _calibration_figures(cal, sess.rig),
                        "poses": cal.poses, "residual_plot": "calibration_residuals.png"},
        "measurements": measurements, "accuracy": accuracy, "stages": st.rows,
        "seconds_total": round(sum(r["seconds"] for r in st.rows), 2),
    }
    if sequences is not None:
        summary["sequences"] = sequences(seed)
        st.rows += [{"name": f"sequence: {k}", "seconds": v["seconds"]} for k, v in summary["sequences"].items()]
        summary["seconds_total"] = round(sum(r["seconds"] for r in st.rows), 2)
    save_summary(out, summary)
    write_report(out)
    return summary


def _write_outputs(out: Path, points, err, masks, metrics, texture) -> list:
    """PLY + npy per object, an error map PNG; returns the summary's measurement entries."""
    _save_npy(out / "points.npy", points)
    entries = []
    for name in ("sculpture", "sphere", "sphere_b"):
        m = masks[name]
        sub = np.where(m[..., None], points, np.nan).astype(np.float32)
        tex = None if texture is None else np.clip(texture / max(float(np.nanmax(texture)), 1e-9), 0, 1)
        write_measurement_ply(out / f"{name}.ply", sub, tex, mask=m)
        _save_npy(out / f"points_{name}.npy", sub)
        if name in metrics:
            _error_png(out / f"error_{name}.png", np.where(m, err, np.nan), f"{name}: 3D error, signed by depth")
            entries.append({"name": name, "points": f"points_{name}.npy", "ply": f"{name}.ply",
                            "metrics": metrics[name], "error_map": f"error_{name}.png"})
    entries.append({"name": "ball bar", "metrics": metrics["ball bar"]})
    return entries


def _save_npy(path: Path, arr: np.ndarray) -> None:
    with atomic_path(path) as tmp:
        np.save(tmp, arr)


def _error_png(path: Path, err: np.ndarray, title: str) -> None:
    """Signed error map ``err`` (H, W) mm as a PNG: diverging colours centred on 0 (limits
    ``±P99(|err|)``), axes in camera pixels of the full image (the crop keeps its coordinates),
    colour bar in mm."""
    import matplotlib  # heavy: loaded only when a figure is written; Agg must be chosen before pyplot
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r0, c0 = 0, 0
    rows, cols = np.nonzero(np.isfinite(err))
    if rows.size:  # crop to the object, with a small margin
        m = 8
        r0, c0 = max(rows.min() - m, 0), max(cols.min() - m, 0)
        err = err[r0:rows.max() + m + 1, c0:cols.max() + m + 1]
    fig, ax = plt.subplots(figsize=(6, 4.5), dpi=100)
    finite = np.abs(err[np.isfinite(err)])
    vmax = float(np.percentile(finite, 99)) if finite.size else 1.0
    h, w = err.shape
    im = ax.imshow(err, cmap="RdBu_r", vmin=-vmax, vmax=vmax, extent=(c0 - 0.5, c0 + w - 0.5, r0 + h - 0.5, r0 - 0.5))
    ax.set_title(title)
    ax.set_xlabel("u (camera px)")
    ax.set_ylabel("v (camera px)")
    fig.colorbar(im, ax=ax, label="measured − truth (mm), + farther from the camera")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", bbox_inches="tight")
    plt.close(fig)
