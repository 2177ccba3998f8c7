"""Checks that every file of an output folder says what it holds (units and provenance); shared by
the tests of the commands that write them."""
from __future__ import annotations

import json
from pathlib import Path

from fringe3d.utils.provenance import read_tiff_description


def outputs(root: Path, suffixes) -> list[Path]:
    """Files under ``root`` with one of ``suffixes``, capture frames excepted."""
    return [f for f in sorted(Path(root).rglob("*")) if f.suffix in suffixes and "frames" not in f.parts]


def check_json_provenance(f: Path) -> None:
    """``f`` carries the fringe3d version, time, command line and units (the folder marker its own)."""
    d = json.loads(f.read_text())
    if f.name == "fringe3d.json":
        assert d["fringe3d"] and d["command"].startswith("fringe3d ") and d["finished"], f
        assert d["units"]["length"] == "mm", f
        return
    p = d.get("provenance")
    assert isinstance(p, dict), f"{f} has no provenance"
    assert p["fringe3d_version"] and p["written"] and p["command"].startswith("fringe3d "), f
    assert isinstance(p["units"], dict) and p["units"], f"{f} names no units"


def check_tiff_description(f: Path) -> None:
    """``f`` names its quantity and unit, the fringe3d version and the command line."""
    d = read_tiff_description(f)
    assert d is not None, f"{f} has no fringe3d description"
    assert d["quantity"] and d["unit"] and d["fringe3d_version"] and d["command"].startswith("fringe3d "), f


def check_ply_header(f: Path, command: str) -> None:
    """``f``'s header says ``comment units: mm`` and the command (``fringe3d COMMAND ...``)."""
    head = f.read_bytes()[:4096].split(b"end_header")[0].decode("ascii")
    assert "comment units: mm" in head and f"comment command: fringe3d {command}" in head, f


def check_folder(root: Path, ply_command: str) -> None:
    """Every JSON, TIFF and PLY under ``root`` (see the checks above)."""
    for f in outputs(root, (".json",)):
        check_json_provenance(f)
    for f in outputs(root, (".tif", ".tiff")):
        check_tiff_description(f)
    for f in outputs(root, (".ply",)):
        check_ply_header(f, ply_command)
