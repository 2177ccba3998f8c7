"""Provenance and units carried by every file a command writes.

A measurement taken elsewhere must say what it is, in which unit, and what made it:

* every JSON file a command writes holds a ``"provenance"`` object (:func:`provenance`)::

      "provenance": {"fringe3d_version": "0.1.0", "written": "2026-12-02T01:49:36+00:00",
                     "command": "fringe3d decode cap -o dec", "units": {"length": "mm", ...}}

  ``units`` maps the file's quantities (or their kinds: ``length``, ``angle``, ``time``) to units;
  readers of fringe3d's own files ignore the object (:func:`without_provenance`);
* every TIFF holds an ``ImageDescription`` tag with the JSON :func:`tiff_description`::

      {"quantity": "depth", "unit": "mm", "fringe3d_version": "0.1.0", "command": "fringe3d reconstruct ..."}

  (no time, so a seeded run gives the same image bytes twice; the folder's ``fringe3d.json`` dates it);
* PLY headers carry ``comment units: mm`` and :func:`fringe3d.utils.output_folder.provenance_comments`.

The folder marker ``fringe3d.json`` carries the version, command and times itself and
:data:`FOLDER_UNITS`, the unit system all files of the folder share.
"""
from __future__ import annotations

import datetime as _dt
import json
from typing import Mapping

__all__ = ["PROVENANCE_KEY", "FOLDER_UNITS", "provenance", "tiff_description", "without_provenance",
           "read_tiff_description", "version", "command_line"]

#: The key of the provenance object in every JSON file fringe3d writes.
PROVENANCE_KEY = "provenance"
#: The unit system of every fringe3d output: lengths in mm, angles and phases in rad, time in s,
#: camera and projector coordinates in pixels, intensities as a fraction of full scale (0-1)
#: unless a file names another unit (e.g. decode's modulation in camera counts).
FOLDER_UNITS = {"length": "mm", "angle": "rad", "phase": "rad", "time": "s", "pixel coordinates": "px",
                "intensity": "fraction of full scale"}


class _CommandLine:
    #: The command line recorded in outputs; the CLI sets it
    #: (:func:`fringe3d.utils.output_folder.set_command_line`).
    text = ""


def command_line() -> str:
    """The command line now writing outputs (``fringe3d ...``; empty outside the CLI)."""
    return _CommandLine.text


def use_command_line(text: str) -> None:
    """Record ``text`` (a whole ``fringe3d ...`` line) as the command writing outputs: a worker
    process writes the command of the client that sent it the work."""
    _CommandLine.text = str(text)


def version() -> str:
    """The installed fringe3d version ("unknown" from a source tree without metadata)."""
    try:
        from importlib.metadata import version as _installed
        return _installed("fringe3d")
    except Exception:  # pragma: no cover - running from a source tree without metadata
        return "unknown"


def provenance(units: Mapping[str, str]) -> dict:
    """The ``"provenance"`` object of a JSON file whose quantities have ``units`` (name -> unit)."""
    return {"fringe3d_version": version(), "written": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "command": command_line(), "units": dict(units)}


def tiff_description(quantity: str, unit: str) -> str:
    """The JSON ``ImageDescription`` of a TIFF holding ``quantity`` in ``unit`` (e.g. "depth", "mm")."""
    return json.dumps({"quantity": quantity, "unit": unit, "fringe3d_version": version(), "command": command_line()})


def read_tiff_description(path) -> dict | None:
    """The parsed :func:`tiff_description` of a TIFF file, or None when it has none (not written by fringe3d)."""
    import tifffile

    with tifffile.TiffFile(path) as tif:
        text = getattr(tif.pages[0], "description", "") if tif.pages else ""
    try:
        d = json.loads(text)
    except (ValueError, TypeError):
        return None
    return d if isinstance(d, dict) else None


def without_provenance(d):
    """``d`` without its top-level ``"provenance"`` object (for readers of fringe3d's own files)."""
    if isinstance(d, dict) and PROVENANCE_KEY in d:
        return {k: v for k, v in d.items() if k != PROVENANCE_KEY}
    return d
