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

from fringe3d.utils.jsonfile import read_json, write_json

SUMMARY_NAME = "summary.json"


def load_summary(folder: str | Path) -> dict:
    """Read and check ``summary.json`` in ``folder``; clear errors for a missing or bad file."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"results folder {folder} does not exist")
    path = folder / SUMMARY_NAME
    if not path.exists():
        raise FileNotFoundError(f"{folder} has no {SUMMARY_NAME}: expected the output of `fringe3d demo` "
                                "or a folder written by fringe3d.report.results.save_summary")
    summary = read_json(path, "results summary")
    if "title" not in summary:
        raise ValueError(f"{path}: missing field 'title'")
    for m in summary.get("measurements", []):
        if "name" not in m:
            raise ValueError(f"{path}: a measurement has no 'name'")
    return summary


def save_summary(folder: str | Path, summary: dict) -> Path:
    """Write ``summary.json`` atomically."""
    path = Path(folder) / SUMMARY_NAME
    write_json(path, summary)
    return path
