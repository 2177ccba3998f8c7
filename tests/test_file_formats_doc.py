"""docs/file-formats.md names every field of the file schemas (the pydantic models, the
calibration file's checked fields, a capture's ``source`` and a decode summary), so the page
cannot fall behind the code."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from fringe3d.calibrate import calibration_file
from fringe3d.calibrate.boards import CircleBoard
from fringe3d.decode import decode
from fringe3d.io.capture_schema import CaptureMeta
from fringe3d.io.capture_source import make_source
from fringe3d.optics.rig_schema import PinholeModel, RigModel, TelecentricModel
from fringe3d.patterns import render_set, sets
from fringe3d.patterns.manifest_schema import FrameModel, ManifestModel, PlanModel
from fringe3d.sim import presets

DOC = Path(__file__).parents[1] / "docs" / "file-formats.md"


def documented() -> set[str]:
    """Every backquoted word of the page."""
    return set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)`", DOC.read_text(encoding="utf-8")))


@pytest.mark.parametrize("model", [CaptureMeta, ManifestModel, FrameModel, PlanModel, RigModel, PinholeModel,
                                   TelecentricModel], ids=lambda m: m.__name__)
def test_every_schema_field_is_documented(model):
    missing = set(model.model_fields) - documented()
    assert not missing, f"{model.__name__} fields not in {DOC.name}: {sorted(missing)}"


def test_every_calibration_file_field_is_documented():
    rig = presets.get("tiny").rig
    stats = {"width": 1, "height": 1, "dist_model": "k1k2", "rms_px": 0.1, "per_pose_rms_px": [0.1]}
    board = CircleBoard(cols=7, rows=5, spacing=10.0, radius=2.0).to_dict()
    cal = calibration_file.Calibration(model="pinhole", rig=rig, camera=stats, projector=stats,
                                       board=board, periods={"v": 18.0},
                                       angles={"v": 0.0}, poses=[], rms={"camera_px": 0.1, "projector_px": 0.1})
    fields = (set(cal.to_dict()) | set(calibration_file._DEVICE_FIELDS) | set(calibration_file._POSE_FIELDS)
              | set(cal.board))
    assert not fields - documented(), sorted(fields - documented())


def test_every_capture_source_and_decode_summary_field_is_documented():
    source = make_source("tiff", "stack.tif", ".", 0, None, file_frames=3)
    ps = sets.phase_shift(16, 3, "v", width=64, height=32)
    d = decode(np.asarray(render_set(ps)) // 2 + 40, ps)  # unsaturated
    summary = d.summary()
    fields = (set(source) | set(summary) | set(summary["directions"]["v"]) | set(summary["info"])
              | set(summary["info"]["frame_checks"]))
    assert not fields - documented(), sorted(fields - documented())
