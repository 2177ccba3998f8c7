"""The results folder a report is built from.

``RESULTS/summary.json`` holds::

    {"title": str,
     "stages": [{"name": str, "seconds": float}, ...],
     "calibration": {"file": "calibration.json", "figures": {...}, "poses": [{...}, ...],
                     "residual_plot": "calibration_residuals.png"},      # optional
     "measurements": [{"name": str, "points": "points_NAME.npy",         # H×W×3 float32, NaN invalid
                       "ply": "NAME.ply", "metrics": {...},
                       "error_map": "error_NAME.png"}, ...],             # optional PNG
     "accuracy": [{"quantity": str, "value": float, "unit": str, "dissertation": str}, ...]}

Paths are relative to the folder. Every field but ``title`` is optional.
"""
from __future__ import annotations

from pathlib import Path

from typing import Any

from pydantic import StrictStr

from fringe3d.utils.jsonfile import read_json, write_json
from fringe3d.utils.schema import FiniteFloat, Open, validate
from fringe3d.utils.output_folder import check_complete

SUMMARY_NAME = "summary.json"
#: Units of a results summary; each figure also names its own ``unit``.
SUMMARY_UNITS = {"length": "mm", "time": "s", "figures": "the unit each figure names"}


class _Stage(Open):
    name: StrictStr
    seconds: FiniteFloat | None = None


class _Measurement(Open):
    name: StrictStr
    points: StrictStr | None = None
    ply: StrictStr | None = None
    error_map: StrictStr | None = None
    metrics: dict[str, Any] | None = None


class _Accuracy(Open):
    quantity: StrictStr
    value: FiniteFloat | None = None
    unit: StrictStr = ""


class SummaryModel(Open):
    """``summary.json``: the fields a report reads are typed; others are kept as free metadata."""

    title: StrictStr
    stages: list[_Stage] = []
    calibration: dict[str, Any] | None = None
    measurements: list[_Measurement] = []
    accuracy: list[_Accuracy] = []


def load_summary(folder: str | Path) -> dict:
    """Read and check ``summary.json`` in ``folder``; clear errors for a missing or bad file."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"results folder {folder} does not exist")
    path = folder / SUMMARY_NAME
    if not path.exists():
        raise FileNotFoundError(f"{folder} has no {SUMMARY_NAME}: expected the output of `fringe3d demo` "
                                "or a folder written by fringe3d.report.results.save_summary")
    check_complete(folder, "results folder")
    summary = read_json(path, "results summary")
    check_file_fields(summary, folder, path)
    validate(SummaryModel, summary, f"results summary {path}")
    return summary


#: Suffixes of the files a summary may name (each must lie inside the results folder).
FILE_SUFFIXES = (".png", ".jpg", ".gif", ".svg", ".npy", ".npz", ".ply", ".json", ".html", ".csv", ".tif", ".tiff",
                 ".vtk", ".vtp", ".vtu", ".pvd", ".zarr", ".txt", ".yaml", ".yml")


def check_file_fields(summary, folder: Path, path: Path, where: str = "") -> None:
    """Refuse a summary that names a file outside ``folder`` (absolute, ``../``, or through a symlink):
    a report embeds the files it names, so it must never read elsewhere."""
    root = folder.resolve()
    if isinstance(summary, dict):
        for k, v in summary.items():
            check_file_fields(v, folder, path, f"{where}.{k}" if where else str(k))
    elif isinstance(summary, list):
        for i, v in enumerate(summary):
            check_file_fields(v, folder, path, f"{where}[{i}]")
    elif isinstance(summary, str) and summary.lower().endswith(FILE_SUFFIXES):
        target = (folder / summary).resolve()
        if Path(summary).is_absolute() or (target != root and root not in target.parents):
            raise ValueError(f"{path}: field {where}: {summary!r} is outside the results folder {folder}; a "
                             "summary may only name files inside its folder (relative paths)")


def save_summary(folder: str | Path, summary: dict) -> Path:
    """Write ``summary.json`` atomically."""
    path = Path(folder) / SUMMARY_NAME
    write_json(path, summary, units=SUMMARY_UNITS)
    return path
