"""``fringe3d decode --compensate harmonic|response`` and the nonlinearity diagnostic in
decoded.json, on simulated captures of a gamma-2.2 and a linear projector (issue 25)."""
import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.decode.result import Decoded
from fringe3d.io.capture import write_capture
from fringe3d.patterns import sets
from fringe3d.patterns.gamma import fit_gamma, save_gamma
from fringe3d.sim import Plane, Scene, presets, render
from fringe3d.sim.virtual_devices import VirtualRigState

PRESET = presets.get("tiny")
PROJ = PRESET.rig.projector


def _settings(gamma: float, bits: int):
    return PRESET.settings.replace(ideal=True, bit_depth=bits, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                   gamma=gamma)


def _scene():
    return Scene([Plane(PRESET.center, (0.1, 0.05, -1.0))])


def _capture(folder, gamma: float, steps: int = 4):
    ps = sets.phase_shift(18, steps, "v", width=PROJ.width, height=PROJ.height)
    frames, truth = render(_scene(), PRESET.rig, ps, _settings(gamma, 16), progress=False)
    write_capture(folder, frames, ps, {"bit_depth": 16})
    return truth.phase["v"], truth.mask


def _gamma_file(path, gamma: float):
    rig = VirtualRigState(PRESET, _scene(), _settings(gamma, 8))
    levels = np.arange(0, 256, 15)
    frames = []
    for k, lv in enumerate(levels):
        rig.set_image(np.full((PROJ.height, PROJ.width), lv, np.uint8))
        frames.append(rig.exposure_image(0.0, k))
    save_gamma(path, fit_gamma(levels, np.stack(frames), full_scale=255))


def _rms(folder, truth, mask) -> float:
    d = Decoded.load(folder)
    m = mask & d.mask["v"]
    return float(np.sqrt(np.mean(np.angle(np.exp(1j * (d.wrapped["v"] - truth)))[m] ** 2)))


def test_decode_diagnoses_gamma_and_compensation_cuts_the_error(tmp_path, capsys):
    truth, mask = _capture(tmp_path / "cap", 2.2)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "raw"), "-q"]) == 0
    assert "projector is nonlinear" in capsys.readouterr().err
    diag = json.loads((tmp_path / "raw" / "decoded.json").read_text())["info"]["radiometry"]["v"]["diagnostic"]
    assert diag["nonlinear"] and diag["gamma"] == pytest.approx(2.2, abs=0.05) and diag["ripple_order"] == 4
    _gamma_file(tmp_path / "gamma.json", 2.2)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "harm"), "-q", "--compensate", "harmonic"]) == 0
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "resp"), "-q",
                 "--response", str(tmp_path / "gamma.json")]) == 0
    raw = _rms(tmp_path / "raw", truth, mask)
    assert _rms(tmp_path / "harm", truth, mask) < raw / 5
    assert _rms(tmp_path / "resp", truth, mask) < raw / 5


def test_decode_stays_quiet_on_a_linear_projector(tmp_path, capsys):
    _capture(tmp_path / "cap", 1.0)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "dec"), "-q"]) == 0
    assert "nonlinear" not in capsys.readouterr().err
    diag = json.loads((tmp_path / "dec" / "decoded.json").read_text())["info"]["radiometry"]["v"]["diagnostic"]
    assert not diag["nonlinear"] and diag["fix"] is None


def test_compensate_response_without_a_response_file_exits_2_before_writing(tmp_path, capsys):
    _capture(tmp_path / "cap", 2.2, steps=3)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "dec"), "--compensate", "response"]) == 2
    assert "--response" in capsys.readouterr().err and not (tmp_path / "dec").exists()


def test_a_response_file_that_is_not_a_gamma_file_exits_2_naming_it(tmp_path, capsys):
    _capture(tmp_path / "cap", 2.2, steps=3)
    (tmp_path / "r.json").write_text(json.dumps({"format": "something-else"}))
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "dec"), "--response",
                 str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert "r.json" in err and "not a projector gamma file" in err and not (tmp_path / "dec").exists()


def test_diagnostic_reads_the_same_subsample_gathered_before_the_method():
    """The decoder gathers the diagnostic's subsample before the direction's method (while the
    frames are cached); the report is the one of a subsample gathered when it is made."""
    from fringe3d.decode import compensation
    from fringe3d.decode.context import DecodeContext, phase_groups
    from fringe3d.decode.options import DecodeOptions
    ps = sets.phase_shift(18, 4, "v", width=PROJ.width, height=PROJ.height)
    frames, _ = render(_scene(), PRESET.rig, ps, _settings(2.2, 16), progress=False)
    reports = []
    for prefetch in (True, False):
        ctx = DecodeContext(frames=frames, patterns=ps, direction="v", plan=ps.plans[0], options=DecodeOptions(),
                            min_modulation=20.0, cache={("phase_groups",): phase_groups(ps, "v")})
        if prefetch:
            compensation.prefetch_sample(ctx, ps.plans[0])
            assert ("radiometry_sample", "v/T18") in ctx.cache
        reports.append(compensation.radiometry_info(ctx, phase_groups(ps, "v")[0]))
    assert reports[0] == reports[1] and reports[0]["diagnostic"]["nonlinear"]
