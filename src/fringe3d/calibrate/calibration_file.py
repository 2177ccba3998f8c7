"""The calibration file: one versioned JSON holding the calibrated rig and how good it is.

Layout (``format = "fringe3d-calibration"``, ``version = 1``)::

    {"format", "version", "model": "pinhole" | "telecentric",
     "rig": Rig.to_dict(),                   # so Rig.load("calib.json") works
     "camera_stats":    {"width", "height", "dist_model", "rms_px", "per_pose_rms_px"},
     "projector_stats": {"width", "height", "dist_model", "rms_px", "per_pose_rms_px"},
     "board":     CircleBoard.to_dict(),
     "periods":   {direction: period (projector px)},   # narrowest period per direction
     "angles":    {direction: fringe angle (rad)},
     "poses":     [{"name", "camera_rms_px", "projector_rms_px", "points"}],
     "rms":       {"camera_px", "projector_px", ...},
     "acceptance": {"passed", "gates": [{"name", "passed", "value", "limit", "advice"}],
                    "dropped_poses", "outlier_rule", "model_choice", "accepted_poor"},
     "extra":     {...}}                      # free-form (e.g. alpha_opt, stereo rms)

``acceptance`` is what the acceptance gates of :mod:`.gates` found (absent in files written
before the gates existed); a file whose ``acceptance.passed`` is false was written with
``fringe3d calibrate --accept-poor``. Files written before the field was renamed hold it as
``quality``: read as ``acceptance`` with a :class:`~fringe3d.utils.warning_types.RenamedFieldWarning`
(fringe3d keeps "quality" for the per-pixel mask reason bits, ``docs/file-formats.md``).

:func:`load_calibration` validates it and names any missing or invalid field;
:func:`export_opencv_yaml` writes the same numbers as an OpenCV ``FileStorage`` YAML. All
writes are atomic.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from fringe3d.optics import Rig, TelecentricCamera
from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.console import to_jsonable
from fringe3d.utils.jsonfile import read_json, write_json
from fringe3d.utils.warning_types import RenamedFieldWarning

FORMAT = "fringe3d-calibration"
VERSION = 1
MODELS = ("pinhole", "telecentric")
_DEVICE_FIELDS = {"width": int, "height": int, "dist_model": str, "rms_px": float, "per_pose_rms_px": list}
_POSE_FIELDS = {"name": str, "camera_rms_px": float, "projector_rms_px": float, "points": int}


@dataclass
class Calibration:
    """A calibrated rig plus its provenance and residual figures (see module doc)."""

    model: str
    rig: Rig
    camera: dict
    projector: dict
    board: dict
    periods: dict
    angles: dict
    poses: list
    rms: dict
    extra: dict = field(default_factory=dict)
    acceptance: dict = field(default_factory=dict)

    @property
    def quality(self) -> dict:
        """Deprecated name of :attr:`acceptance` (warns)."""
        warnings.warn("Calibration.quality is renamed Calibration.acceptance (the acceptance gates); "
                      "'quality' means the mask reason bits in fringe3d", RenamedFieldWarning, stacklevel=2)
        return self.acceptance

    def to_dict(self) -> dict:
        return to_jsonable({"format": FORMAT, "version": VERSION, "model": self.model, "rig": self.rig.to_dict(),
                            "camera_stats": self.camera, "projector_stats": self.projector, "board": self.board,
                            "periods": self.periods, "angles": self.angles, "poses": self.poses,
                            "rms": self.rms, ACCEPTANCE: self.acceptance, "extra": self.extra})

    def save(self, path) -> Path:
        """Write the JSON atomically; returns the path."""
        path = Path(path)
        write_json(path, self.to_dict(), allow_nan=False, units=CALIBRATION_UNITS)
        return path

    @classmethod
    def from_dict(cls, d: dict, where: str = "calibration file") -> "Calibration":
        d = renamed_fields(d, where)
        validate(d, where)
        rig = Rig.from_dict(d["rig"], f"{where}: field rig")
        return cls(model=d["model"], rig=rig, camera=d["camera_stats"],
                   projector=d["projector_stats"], board=d["board"],
                   periods=d["periods"], angles=d["angles"], poses=d["poses"], rms=d["rms"],
                   extra=d.get("extra", {}), acceptance=d.get(ACCEPTANCE, {}))

    def export_opencv_yaml(self, path) -> Path:
        return export_opencv_yaml(self, path)


#: Units of a calibration file's fields (its ``provenance``); the rig's as in a rig file.
CALIBRATION_UNITS = {"length": "mm", "rig": "as a rig file (K px, t mm)", "rms": "px (reprojection)",
                     "periods": "projector px", "angles": "rad", "spacing": "mm"}


#: The calibration file's field of the acceptance gates, and its name in files written before.
ACCEPTANCE = "acceptance"
OLD_ACCEPTANCE = "quality"


def renamed_fields(d: dict, where: str = "calibration file") -> dict:
    """``d`` with the acceptance gates under :data:`ACCEPTANCE`: a file written before the
    rename holds them as ``quality``, read with a
    :class:`~fringe3d.utils.warning_types.RenamedFieldWarning` naming ``where``.

    Parameters
    ----------
    d : dict
        A calibration dict as read from JSON.
    where : str
        What to name in the warning (the file).

    Returns
    -------
    dict
        ``d`` itself, or a copy with the old field renamed.
    """
    if not isinstance(d, dict) or OLD_ACCEPTANCE not in d or ACCEPTANCE in d:
        return d
    warnings.warn(f"{where}: field {OLD_ACCEPTANCE!r} is the old name of {ACCEPTANCE!r} (the calibration's "
                  f"acceptance gates); read as {ACCEPTANCE!r}. Write the file again to update it",
                  RenamedFieldWarning, stacklevel=3)
    out = {k: v for k, v in d.items() if k != OLD_ACCEPTANCE}
    out[ACCEPTANCE] = d[OLD_ACCEPTANCE]
    return out


def _need(d: dict, key: str, typ, where: str):
    if not isinstance(d, dict):
        raise ValueError(f"{where}: expected an object, got {type(d).__name__}")
    if key not in d:
        raise ValueError(f"{where}: missing field {key!r}")
    v = d[key]
    ok = isinstance(v, typ) if typ is not float else (isinstance(v, (int, float)) and not isinstance(v, bool))
    if typ is int:
        ok = isinstance(v, int) and not isinstance(v, bool)
    if not ok:
        raise ValueError(f"{where}: field {key!r} must be {typ.__name__}, got {type(v).__name__} ({v!r})")
    if typ is float and not math.isfinite(float(v)):
        raise ValueError(f"{where}: field {key!r} must be finite, got {v!r}")
    return v


def validate(d: dict, where: str = "calibration file") -> None:
    """Raise ``ValueError`` naming the first missing or invalid field of a calibration dict."""
    if not isinstance(d, dict):
        raise ValueError(f"{where}: expected a JSON object at the top level")
    fmt = _need(d, "format", str, where)
    if fmt != FORMAT:
        raise ValueError(f"{where}: field 'format' is {fmt!r}, expected {FORMAT!r}")
    ver = _need(d, "version", int, where)
    if ver > VERSION or ver < 1:
        raise ValueError(f"{where}: version {ver} is not supported (this fringe3d reads version {VERSION})")
    model = _need(d, "model", str, where)
    if model not in MODELS:
        raise ValueError(f"{where}: field 'model' is {model!r}, expected one of {MODELS}")
    _need(d, "rig", dict, where)
    rig = Rig.from_dict(d["rig"], f"{where}: field rig")
    if rig.telecentric != (model == "telecentric"):
        raise ValueError(f"{where}: model {model!r} does not match the rig's camera kind")
    for dev in ("camera", "projector"):
        sub = _need(d, f"{dev}_stats", dict, where)
        for k, typ in _DEVICE_FIELDS.items():
            _need(sub, k, typ, f"{where}: {dev}_stats")
        rd = getattr(rig, dev)
        if (sub["width"], sub["height"]) != (rd.width, rd.height):
            raise ValueError(f"{where}: {dev} size {sub['width']}x{sub['height']} does not match the rig's "
                             f"{rd.width}x{rd.height}")
    board = _need(d, "board", dict, where)
    for k in ("cols", "rows", "spacing"):
        _need(board, k, float if k == "spacing" else int, f"{where}: board")
    periods = _need(d, "periods", dict, where)
    if not periods:
        raise ValueError(f"{where}: field 'periods' is empty; expected the fringe period per direction")
    for k, v in periods.items():
        _need(periods, k, float, f"{where}: periods")
        if not v > 0:
            raise ValueError(f"{where}: periods[{k!r}] must be > 0, got {v}")
    _need(d, "angles", dict, where)
    poses = _need(d, "poses", list, where)
    for i, p in enumerate(poses):
        _need(p, "name", str, f"{where}: poses[{i}]")
        _need(p, "points", int, f"{where}: poses[{i}]")
    rms = _need(d, "rms", dict, where)
    for k in ("camera_px", "projector_px"):
        _need(rms, k, float, f"{where}: rms")
    d = renamed_fields(d, where)
    if ACCEPTANCE in d and d[ACCEPTANCE]:
        _need(d, ACCEPTANCE, dict, where)
        _need(d[ACCEPTANCE], "passed", bool, f"{where}: {ACCEPTANCE}")
        _need(d[ACCEPTANCE], "gates", list, f"{where}: {ACCEPTANCE}")


def load_calibration(path) -> Calibration:
    """Read and validate a calibration JSON (errors name the missing/invalid field).

    Parameters
    ----------
    path : str or Path
        The calibration JSON written by ``fringe3d calibrate`` (``calibration.json``).

    Returns
    -------
    Calibration
        The calibrated rig (mm, px) with its provenance and residual figures.
    """
    path = Path(path)
    d = read_json(path, "calibration file", require_object=False)
    return Calibration.from_dict(d, where=str(path))


def export_opencv_yaml(cal: Calibration, path) -> Path:
    """Write the calibration as an OpenCV ``FileStorage`` YAML (atomic).

    Nodes: ``model``, ``camera_K`` / ``camera_dist`` (pinhole) or ``camera_M`` (telecentric),
    ``camera_size``, ``projector_K``, ``projector_dist``, ``projector_size``, ``R``, ``T``
    (world -> projector), ``camera_rms``, ``projector_rms`` and ``period_<direction>``.

    Parameters
    ----------
    cal : Calibration
        The calibration to export.
    path : str or Path
        The YAML file to write.

    Returns
    -------
    Path
        ``path``.
    """
    return export_rig_opencv_yaml(cal.rig, path, _figures(cal))


def export_rig_opencv_yaml(rig: Rig, path, extra: dict | None = None) -> Path:
    """Write a rig as an OpenCV ``FileStorage`` YAML (atomic): the nodes of
    :func:`export_opencv_yaml` up to ``T`` (mm), then ``extra`` (name -> float)."""
    path = Path(path)
    model = "telecentric" if rig.telecentric else "pinhole"
    with atomic_path(path, suffix=".yaml") as tmp:
        fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_FORMAT_YAML)
        try:
            fs.write("format", FORMAT)
            fs.write("version", VERSION)
            fs.write("model", model)
            cam, prj = rig.camera, rig.projector
            if isinstance(cam, TelecentricCamera):
                fs.write("camera_M", np.asarray(cam.M, np.float64))
            else:
                fs.write("camera_K", np.asarray(cam.K, np.float64))
                fs.write("camera_dist", np.asarray(cam.dist, np.float64).reshape(1, -1))
            fs.write("camera_size", np.array([[cam.width, cam.height]], np.int32))
            fs.write("projector_K", np.asarray(prj.K, np.float64))
            fs.write("projector_dist", np.asarray(prj.dist, np.float64).reshape(1, -1))
            fs.write("projector_size", np.array([[prj.width, prj.height]], np.int32))
            fs.write("R", np.asarray(prj.R, np.float64))
            fs.write("T", np.asarray(prj.t, np.float64).reshape(3, 1))
            for k, v in (extra or {}).items():
                fs.write(k, float(v))
        finally:
            fs.release()
    return path


def rig_for_export(path) -> tuple[Rig, dict]:
    """The rig of a calibration JSON (with its ``camera_rms``, ``projector_rms`` and
    ``period_<d>`` figures for :func:`export_rig_opencv_yaml`) or of a plain rig JSON
    (``Rig.save``, ``fringe3d calibrate --import-opencv``; no figures). Errors name the file and the field."""
    path = Path(path)
    d = read_json(path, "calibration file", require_object=False)
    if isinstance(d, dict) and d.get("format") == FORMAT:
        cal = Calibration.from_dict(d, where=str(path))
        return cal.rig, _figures(cal)
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected a calibration or rig JSON object at the top level")
    return Rig.from_dict(d.get("rig", d), f"{path}: field rig"), {}


def _figures(cal: Calibration) -> dict:
    return {"camera_rms": float(cal.rms["camera_px"]), "projector_rms": float(cal.rms["projector_px"]),
            **{f"period_{k}": float(v) for k, v in cal.periods.items()}}
