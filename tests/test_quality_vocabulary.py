""""quality" has one meaning in fringe3d: the per-pixel mask reason bits of
:mod:`fringe3d.decode.edges` (docs/file-formats.md, "Vocabulary: quality"). Every file field,
array and report label spelt ``quality`` holds or describes those bits; what was once also called
quality (the PLY's roughness, the report's modulation, the calibration file's gates) has its own
name, and the old calibration field is still read, with a warning."""
from __future__ import annotations

import json
import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from fringe3d.calibrate import calibration_file, gates
from fringe3d.decode import edges
from fringe3d.io.decoded_files import MAP_UNITS
from fringe3d.io.export import write_points
from fringe3d.io.ply_standard import measurement_scalars, write_measurement_ply
from fringe3d.io.store import QUALITY_ATTRS
from fringe3d.report.discover import DISCRETE_KINDS, MAP_KINDS
from fringe3d.sim import presets
from fringe3d.utils.warning_types import RenamedFieldWarning

#: Every reason bit of the quality map: name -> value.
BITS = {"invalid": edges.INVALID, "edge": edges.EDGE, "inconsistent": edges.INCONSISTENT,
        "gradient": edges.GRADIENT, "mod_drop": edges.MOD_DROP, "rim": edges.RIM, "order": edges.ORDER,
        "saturated": edges.SATURATED}


def test_every_array_named_quality_is_described_as_the_reason_bits():
    assert sorted(BITS.values()) == [1 << k for k in range(8)]  # uint8: one bit per reason
    assert "bit" in MAP_UNITS["quality"] and "fringe3d.decode.edges" in MAP_UNITS["quality"]
    assert "bits" in QUALITY_ATTRS["long_name"] and "fringe3d.decode.edges" in QUALITY_ATTRS["long_name"]
    assert dict(zip(QUALITY_ATTRS["flag_meanings"].split(), QUALITY_ATTRS["flag_masks"])) == BITS


def test_the_report_says_quality_only_of_the_reason_bit_map():
    labelled = [(stem, title) for stem, title, *_ in MAP_KINDS if "quality" in f"{stem} {title}".lower()]
    assert labelled == [("quality", "quality: first reason a pixel was flagged")]
    assert "quality" in DISCRETE_KINDS  # drawn as categories (one per reason), not a colour bar
    modulation = [title for stem, title, *_ in MAP_KINDS if stem == "modulation"]
    assert modulation == ["fringe modulation"]


def plane(h=8, w=10):
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.stack([u, v, 400 + 0.1 * u], -1), np.full((h, w), 0.01, np.float32)


def test_no_point_file_has_a_field_named_quality(tmp_path):
    P, sigma = plane()
    scalars = measurement_scalars(P, sigma)
    assert set(scalars) == {"sigma_z_mm", "roughness_mm"}
    head = write_measurement_ply(tmp_path / "p.ply", P, sigma_z=sigma).read_bytes().split(b"end_header")[0]
    ply_fields = re.findall(rb"^property \w+ (\w+)$", head, re.M)
    assert b"scalar_roughness_mm" in ply_fields and not [f for f in ply_fields if b"quality" in f]
    vtp = ET.parse(write_points(tmp_path / "p.vtp", P, scalars))
    names = [a.get("Name") for a in vtp.iter("DataArray") if a.get("Name")]
    assert "roughness_mm" in names and not [n for n in names if "quality" in n.lower()]


def calibration_dict():
    rig = presets.get("tiny").rig

    def stats(dev):
        return {"width": dev.width, "height": dev.height, "dist_model": "k1k2", "rms_px": 0.1,
                "per_pose_rms_px": [0.1]}
    cal = calibration_file.Calibration(model="pinhole", rig=rig, camera=stats(rig.camera),
                                       projector=stats(rig.projector), board={"cols": 7, "rows": 5, "spacing": 10.0},
                                       periods={"v": 18.0}, angles={"v": 0.0}, poses=[],
                                       rms={"camera_px": 0.1, "projector_px": 0.1},
                                       acceptance={"passed": True, "gates": [], "dropped_poses": []})
    return cal.to_dict()


def test_calibration_file_keeps_its_gates_under_acceptance_and_reads_the_old_quality_field_with_a_warning(tmp_path):
    d = calibration_dict()
    assert "quality" not in d and d["acceptance"]["passed"] is True
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = tmp_path / "new.json"
        new.write_text(json.dumps(d))
        assert calibration_file.load_calibration(new).acceptance == d["acceptance"]
    old = tmp_path / "old.json"
    d["quality"] = d.pop("acceptance")
    old.write_text(json.dumps(d))
    with pytest.warns(RenamedFieldWarning, match=r"old\.json: field 'quality' is the old name of 'acceptance'"):
        cal = calibration_file.load_calibration(old)
    assert cal.acceptance == d["quality"] and "quality" not in cal.to_dict()
    with pytest.warns(RenamedFieldWarning, match="Calibration.acceptance"):
        assert cal.quality is cal.acceptance
    with pytest.warns(RenamedFieldWarning, match="AcceptanceGateError"):
        assert gates.QualityGateError is gates.AcceptanceGateError


def test_a_bad_old_quality_field_is_refused_under_its_new_name(tmp_path):
    d = calibration_dict()
    d["quality"] = {"passed": "yes", "gates": []}
    del d["acceptance"]
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.warns(RenamedFieldWarning), pytest.raises(ValueError, match=r"bad\.json: acceptance: field 'passed'"):
        calibration_file.load_calibration(tmp_path / "bad.json")
