"""What a results folder holds, for a report: whatever fringe3d command wrote it.

:func:`discover` looks for (all optional, all inside the folder)

* ``fringe3d.json`` - provenance (version, command, start / finish, inputs, fingerprint);
* a calibration: a JSON with ``format`` ``fringe3d-calibration`` or ``fringe3d-rig`` in the
  folder, the calibration a ``reconstruct.json`` names, or RESULTS itself when it is such a file;
* ``evaluate.json`` (figures), ``reconstruct.json`` / ``decoded.json`` / ``summary.json``
  (summaries shown as key-value tables);
* point data: ``points.npy`` (H, W, 3) or the first complete frame of ``points.zarr``;
* a ``fringe3d merge`` folder: ``merge.json``, ``fused.ply`` and ``mesh.ply`` (:mod:`.multiview_view`);
* maps: the ``.tif`` images (residuals, 3D error, modulation, mask, depth, phase, texture) and
  ``.png`` figures (``maps/``, calibration residual plots).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fringe3d.io.arrays import load_array
from fringe3d.io.images import read_image
from fringe3d.io.store import PointMapStore
from fringe3d.utils.jsonfile import read_json
from fringe3d.utils.output_folder import MARKER_NAME, check_complete, read_marker

from .multiview_view import read_merge
from .strain_view import strain_series

CALIBRATION_FORMATS = ("fringe3d-calibration", "fringe3d-rig")
SUMMARY_JSONS = ("reconstruct.json", "decoded.json", "summary.json")
MAX_MAPS = 16
MAX_PNGS = 8

#: Map kinds drawn as categories with a legend (:mod:`.map_view`), not a continuous colour bar.
DISCRETE_KINDS = ("mask", "quality")
#: file stem prefix -> (title, unit, plotly colour scale, centred on zero), in page order
MAP_KINDS = (
    ("truth_error", "3D error against the truth, signed by depth (+ farther)", "mm", "RdBu_r", True),
    ("plane_residuals", "plane residuals (signed distance to the fit)", "mm", "RdBu", True),
    ("sphere_residuals", "sphere residuals (|p - c| - r)", "mm", "RdBu", True),
    ("sigma_z", "predicted depth standard deviation σ_z", "mm", "Viridis", False),
    ("quality", "quality: first reason a pixel was flagged", "", "", False),
    ("modulation", "fringe modulation", "counts", "Viridis", False),
    ("mask", "valid-pixel mask", "", "", False),
    ("depth", "depth", "mm", "Viridis", False),
    ("phase_sigma", "phase standard deviation σ_φ", "rad", "Viridis", False),
    ("phase", "absolute phase", "rad", "Viridis", False),
    ("wrapped", "wrapped phase", "rad", "RdBu", False),
    ("average", "average intensity", "counts", "Greys", False),
    ("texture", "texture (white-light intensity)", "fraction of full scale", "Greys", False),
)


@dataclass
class MapItem:
    """One (H, W) map: file ``name``, ``title``, ``unit``, plotly ``colorscale``, ``centred``;
    ``discrete`` names a categorical kind (``"mask"``, ``"quality"``) or is None."""

    name: str
    title: str
    unit: str
    colorscale: str
    centred: bool
    values: np.ndarray
    discrete: str | None = None


@dataclass
class FolderContents:
    """What :func:`discover` found (fields empty / None when absent)."""

    folder: Path
    name: str | None = None
    marker: dict | None = None
    calibration: dict | None = None
    calibration_source: str | None = None
    evaluation: dict | None = None
    summaries: dict = field(default_factory=dict)
    points: np.ndarray | None = None
    points_source: str | None = None
    maps: list = field(default_factory=list)
    pngs: list = field(default_factory=list)
    strain: dict | None = None
    merge: dict | None = None


def _json_format(path: Path) -> str | None:
    try:
        d = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError):
        return None
    return d.get("format") if isinstance(d, dict) else None


def _calibration_named(folder: Path, summary: dict) -> tuple[dict, str] | None:
    """The calibration a reconstruct summary names, if a copy lies inside ``folder`` (a report
    reads nothing outside its results folder) and is a fringe3d rig / calibration file."""
    name = summary.get("calibration")
    if not isinstance(name, str) or not name.endswith(".json"):
        return None
    root = folder.resolve()
    for p in (folder / name, folder / Path(name).name):
        inside = p.resolve() == root or root in p.resolve().parents
        if inside and p.is_file() and _json_format(p) in CALIBRATION_FORMATS:
            return read_json(p, "calibration"), str(p)
    return None


def map_kind(stem: str):
    """The :data:`MAP_KINDS` row of a map file stem (``phase_v`` -> phase), or None."""
    for row in MAP_KINDS:
        if stem == row[0] or stem.startswith(row[0] + "_"):
            return row
    return None


def _maps(folder: Path) -> list[MapItem]:
    items = []
    for p in sorted(folder.glob("*.tif")):
        row = map_kind(p.stem)
        if row is None:
            continue
        values = np.asarray(read_image(p), np.float32)
        if values.ndim != 2:
            continue
        suffix = p.stem[len(row[0]):].strip("_")
        mask = folder / f"mask_{suffix}.tif"
        if row[0] == "phase_sigma" and mask.is_file():  # sigma only where the phase is valid
            m = np.asarray(read_image(mask))
            if m.shape == values.shape:
                values = np.where(m > 0, values, np.nan).astype(np.float32)
        discrete = row[0] if row[0] in DISCRETE_KINDS else None
        items.append((MAP_KINDS.index(row), MapItem(p.name, row[1] + (f" ({suffix})" if suffix else ""),
                                                    row[2], row[3], row[4], values, discrete)))
    return [m for _, m in sorted(items, key=lambda t: (t[0], t[1].name))][:MAX_MAPS]


def _points(folder: Path) -> tuple[np.ndarray | None, str | None]:
    if (folder / "points.npy").is_file():
        return load_array(folder / "points.npy", "point map"), "points.npy"
    if (folder / "points.zarr").is_dir():
        st = PointMapStore.open_existing(folder / "points.zarr")
        for k in range(st.frames):
            if st.is_done(k):
                return st.read(k), f"points.zarr frame {k}"
    return None, None


def discover(results: str | Path) -> FolderContents:
    """Everything a report can show from ``results`` (a command's output folder, or a
    calibration JSON file)."""
    results = Path(results)
    if results.is_file():
        if _json_format(results) not in CALIBRATION_FORMATS:
            raise ValueError(f"{results}: expected a results folder or a fringe3d calibration JSON")
        c = FolderContents(results.parent, name=results.name, calibration=read_json(results, "calibration"),
                           calibration_source=results.name)
        pngs = (results.with_suffix(".png"), results.with_name(results.stem + "_residuals.png"))
        c.pngs = [p for p in pngs if p.is_file()][:1]  # the residual plot `calibrate --plot` / the demo writes
        return c
    if not results.is_dir():
        raise FileNotFoundError(f"results folder {results} does not exist")
    check_complete(results, "results folder")
    c = FolderContents(results, marker=read_marker(results))
    for name in SUMMARY_JSONS:
        if (results / name).is_file():
            c.summaries[name] = read_json(results / name, name)
    if (results / "evaluate.json").is_file():
        c.evaluation = read_json(results / "evaluate.json", "evaluation")
    for p in sorted(results.glob("*.json")):
        if p.name != MARKER_NAME and _json_format(p) in CALIBRATION_FORMATS:
            c.calibration, c.calibration_source = read_json(p, "calibration"), p.name
            png = p.with_suffix(".png")
            if png.is_file():
                c.pngs.append(png)
            break
    if c.calibration is None and "reconstruct.json" in c.summaries:
        found = _calibration_named(results, c.summaries["reconstruct.json"])
        if found:
            c.calibration, c.calibration_source = found
    c.points, c.points_source = _points(results)
    c.maps = _maps(results)
    c.merge = read_merge(results)
    rate = (c.summaries.get("summary.json") or {}).get("frame_rate_hz")
    c.strain = strain_series(results, rate if isinstance(rate, (int, float)) and rate > 0 else None)
    maps = sorted((results / "maps").glob("*.png")) if (results / "maps").is_dir() else []
    if c.strain is not None and maps:  # the plot over time replaces the stack: one map, the peak frame
        peak = results / "maps" / f"strain_{c.strain['peak_frame']:05d}.png"
        maps = [peak if peak.is_file() else maps[0]]
    c.pngs += maps[:MAX_PNGS]
    if not (c.marker or c.calibration or c.evaluation or c.summaries or c.points is not None or c.maps or c.pngs
            or c.strain or c.merge):
        raise ValueError(f"nothing to report in {results}: it holds no fringe3d output (no fringe3d.json, summary, "
                         "evaluation, calibration, point map or figures); give a folder a fringe3d command wrote")
    return c
