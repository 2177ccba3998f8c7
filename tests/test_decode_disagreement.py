"""Issue 25: ``compensate="disagreement"`` (``--compensate disagreement``) corrects the ripple of a
nonlinear projector in 3-step multi-frequency captures from the disagreement between their own
frequencies (after Xing & Guo 2018), against the simulator's true phase."""
import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.decode import DecodeOptions, decode
from fringe3d.decode.result import Decoded
from fringe3d.io.capture import write_capture
from fringe3d.patterns import sets
from fringe3d.radiometry.phase_error import wrap
from fringe3d.sim import Plane, Scene, presets, render

PRESET = presets.get("tiny")
PROJ = PRESET.rig.projector


def _capture(gamma: float, plan: str, **noise):
    """Frames, pattern set and truth of a tilted plane; ``noise`` overrides the noiseless settings."""
    s = PRESET.settings.replace(**({"ideal": True, "bit_depth": 16, "read_noise": 0.0, "shot_noise": False,
                                    "camera_blur": 0.0} | noise), gamma=gamma)
    ps = (sets.three_frequency("v", steps=(3, 3, 3), width=PROJ.width, height=PROJ.height) if plan == "three"
          else sets.hierarchical([18, 23, 256], 3, "v", width=PROJ.width, height=PROJ.height))
    frames, truth = render(Scene([Plane(PRESET.center, (0.1, 0.05, -1.0))]), PRESET.rig, ps, s, progress=False)
    return frames, ps, truth


def _rms(decoded: Decoded, truth) -> float:
    """RMS (rad) of the decoded wrapped phase against the truth over all pixels of the plane."""
    return float(np.sqrt(np.mean(wrap(decoded.wrapped["v"] - truth.phase["v"])[truth.mask] ** 2)))


@pytest.mark.parametrize("plan", ["three", "hierarchical"])
def test_disagreement_compensation_cuts_the_3_step_error_fivefold_and_keeps_the_pixels(plan):
    frames, ps, truth = _capture(2.2, plan)
    raw = decode(frames, ps, rig=PRESET.rig)
    fixed = decode(frames, ps, rig=PRESET.rig, options=DecodeOptions(compensate="disagreement"))
    assert _rms(raw, truth) > 0.1
    assert _rms(fixed, truth) < _rms(raw, truth) / 5
    # the absolute phase too, and every pixel of the plane valid again (the ripple broke orders)
    assert fixed.mask["v"][truth.mask].mean() > 0.98
    m = fixed.mask["v"] & truth.mask
    assert np.sqrt(np.mean((fixed.phase["v"] - truth.phase["v"])[m] ** 2)) < _rms(raw, truth) / 5
    done = fixed.info["radiometry"]["v"]["compensation"]
    assert {d["group"] for d in done if d["applied"]} == set(ps.groups(direction="v", role="phase"))  # all groups


def test_disagreement_compensation_leaves_a_linear_projector_as_it_is():
    frames, ps, truth = _capture(1.0, "three", ideal=False, bit_depth=8)
    raw = decode(frames, ps, rig=PRESET.rig)
    fixed = decode(frames, ps, rig=PRESET.rig, options=DecodeOptions(compensate="disagreement"))
    assert _rms(raw, truth) > 1e-3  # a noisy capture: "unchanged" is within its noise
    assert abs(_rms(fixed, truth) - _rms(raw, truth)) < 0.1 * _rms(raw, truth)
    assert abs(int(fixed.mask["v"].sum()) - int(raw.mask["v"].sum())) <= 0.01 * raw.mask["v"].size


def test_cli_compensate_disagreement_cuts_the_error(tmp_path):
    frames, ps, truth = _capture(2.2, "three")
    write_capture(tmp_path / "cap", frames, ps, {"bit_depth": 16})
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "raw"), "-q"]) == 0
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "fix"), "-q",
                 "--compensate", "disagreement"]) == 0
    assert _rms(Decoded.load(tmp_path / "fix"), truth) < _rms(Decoded.load(tmp_path / "raw"), truth) / 5
    info = json.loads((tmp_path / "fix" / "decoded.json").read_text())["info"]["radiometry"]["v"]
    assert all(d["compensation"] == "disagreement" and d["applied"] for d in info["compensation"])


def test_cli_compensate_disagreement_without_a_second_equal_step_frequency_exits_2_before_writing(tmp_path, capsys):
    ps = sets.phase_shift(18, 3, "v", width=PROJ.width, height=PROJ.height)
    frames, _ = render(Scene([Plane(PRESET.center, (0.1, 0.05, -1.0))]), PRESET.rig, ps,
                       PRESET.settings.replace(ideal=True, bit_depth=16, gamma=2.2), progress=False)
    write_capture(tmp_path / "cap", frames, ps, {"bit_depth": 16})
    code = main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "dec"), "--compensate", "disagreement"])
    err = capsys.readouterr().err
    assert code == 2 and "--compensate disagreement" in err and "Traceback" not in err
    assert not (tmp_path / "dec").exists()


def test_library_refuses_disagreement_on_a_single_frequency_plan():
    ps = sets.phase_shift(18, 3, "v", width=PROJ.width, height=PROJ.height)
    with pytest.raises(ValueError, match="compensate='disagreement'.*direction 'v'"):
        decode(np.full((3, 8, 8), 0.5, np.float32), ps, options=DecodeOptions(compensate="disagreement"))
