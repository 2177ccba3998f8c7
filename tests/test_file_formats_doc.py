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
from fringe3d.patterns.manifest_schema import FrameModel, ManifestModel, PlanModel, PlanOptionsModel
from fringe3d.sim import presets

DOC = Path(__file__).parents[1] / "docs" / "file-formats.md"


def documented() -> set[str]:
    """Every backquoted word of the page."""
    return set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)`", DOC.read_text(encoding="utf-8")))


@pytest.mark.parametrize("model", [CaptureMeta, ManifestModel, FrameModel, PlanModel, PlanOptionsModel, RigModel,
                                   PinholeModel, TelecentricModel], ids=lambda m: m.__name__)
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


SRC = Path(__file__).parents[1] / "src" / "fringe3d"
#: How the library reads or writes a plan option: ``method_option("x"``, ``options.get("x"``, ``options["x"]``.
OPTION_USE = re.compile(r"""(?:\bmethod_option\(|\boptions\.get\(|\boptions\[)\s*["']([a-z_]+)["']""")


def built_plan_options() -> set[str]:
    """Every plan option key the pattern-set builders and layouts write (all sets, both directions)."""
    from fringe3d.commands.patterns import SETS, build_set
    from fringe3d.io.importer import ImportLayout, layout_patterns
    from fringe3d.patterns.layouts import opencv_graycode

    sets_ = [build_set(name, None, None, "v,h" if name not in ("calibration", "optimal-angle") else "v",
                       30.0 if name == "optimal-angle" else None, "sinusoid", 64, 48, None) for name in SETS]
    sets_ += [sets.binary_fine_calibration(800, 600), sets.binary_modified_ftp(800, 600), opencv_graycode(64, 48),
              layout_patterns(ImportLayout("gray-code", (64, 48), period=4, direction="v,h", inverse=False,
                                           interleave=True, threshold=100))]
    return {k for ps in sets_ for p in ps.plans for k in p.options}


def test_every_plan_option_the_library_writes_or_reads_is_in_the_schema_and_documented():
    used = {m for f in SRC.rglob("*.py") for m in OPTION_USE.findall(f.read_text(encoding="utf-8"))}
    plan_options = (used - {"name"}) | built_plan_options()
    known = set(PlanOptionsModel.model_fields)
    assert not plan_options - known, f"plan options missing from PlanOptionsModel: {sorted(plan_options - known)}"
    assert not known - documented(), f"plan options not in {DOC.name}: {sorted(known - documented())}"


def test_the_page_states_the_intensity_law_shift_sign_code_polarity_and_stripe_placement():
    text = " ".join(DOC.read_text(encoding="utf-8").split())
    for fact in ("I = ½ (1 + cos(2π w / T + δ))", "δ = +2π k / N", "white (1) where its bit of the codeword is 1",
                 "[w0 + c T, w0 + (c + 1) T)", "c ^ (c >> 1)"):
        assert fact in text, fact
    # and they are what fringe3d renders: a 4-step set and a 1-px Gray code at pixel centres
    ps = sets.phase_shift(8.0, 4, "v", width=16, height=2)
    u = np.arange(16)
    for k, img in enumerate(render_set(ps)):
        law = 255 * 0.5 * (1 + np.cos(2 * np.pi * u / 8 + 2 * np.pi * k / 4))
        assert np.abs(img[0] - law).max() <= 0.5 + 1e-9  # round(255 I); a negative sign would be off by ~255
    code = sets.gray_code(1.0, "v", width=16, height=2, inverse=True)
    g = u ^ (u >> 1)
    for f, img in zip(code.frames, render_set(code)):
        bit = (g >> (f.bits - 1 - f.bit)) & 1
        np.testing.assert_array_equal(img[0] // 255, 1 - bit if f.inverse else bit)


def test_a_manifest_with_a_phase_group_no_plan_uses_warns_naming_it(tmp_path):
    import warnings

    from fringe3d.patterns.manifest import PatternSet
    from fringe3d.utils.warning_types import DataQualityWarning

    ps = sets.three_frequency("v", width=64, height=48)
    d = ps.to_dict()
    d["plans"][0]["periods"] = d["plans"][0]["periods"][:1]
    d["plans"][0]["method"] = "none"
    with pytest.warns(DataQualityWarning, match=r"v/T21.*v/T144|v/T144.*v/T21"):
        PatternSet.from_dict(d)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        PatternSet.from_dict(ps.to_dict())  # every group used: no warning
