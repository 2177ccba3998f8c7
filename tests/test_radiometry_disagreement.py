"""Issue 25: the projector's ripple estimated from the disagreement between two fringe
frequencies of 3-step sets (after Xing & Guo 2018), where the harmonic model (N >= 4) cannot
apply, against the simulator's true phase."""
import numpy as np
import pytest

from fringe3d.decode import decode
from fringe3d.patterns import sets
from fringe3d.phase.psp import wrapped_phase
from fringe3d.radiometry import disagreement_lut, lut_from_response, power_law
from fringe3d.radiometry.phase_error import wrap
from fringe3d.sim import Plane, Scene, presets, render

PRESET = presets.get("tiny")
_X = np.linspace(0.0, 1.0, 33)
KNEE = tuple(np.where(_X < 0.75, 0.9 * (_X / 0.75) ** 2, 0.9 + 0.1 * (_X - 0.75) / 0.25).tolist())


def _two_frequencies(**response):
    """Per period: the measured wrapped phase, the absolute phase (orders from the truth) and the truth."""
    s = PRESET.settings.replace(ideal=True, bit_depth=16, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                **response)
    scene = Scene([Plane(PRESET.center, (0.1, 0.05, -1.0))])
    out = {}
    for period in (18, 23):
        ps = sets.phase_shift(period, 3, "v", width=PRESET.rig.projector.width,
                              height=PRESET.rig.projector.height)
        frames, truth = render(scene, PRESET.rig, ps, s, progress=False)
        wrapped = wrapped_phase(frames.astype(float)).phase
        true_abs = 2 * np.pi * truth.up / period
        out[period] = (wrapped, true_abs + wrap(wrapped - true_abs), truth)
    return out


@pytest.mark.parametrize("response", [{"gamma": 2.2}, {"response": KNEE}], ids=["gamma2.2", "knee"])
def test_two_frequency_disagreement_cuts_the_3_step_error_fivefold(response):
    out = _two_frequencies(**response)
    wrapped, absolute, truth = out[18]
    lut = disagreement_lut(absolute, 18, out[23][1], 23, steps=3, mask=truth.mask)

    def rms(phase):
        return float(np.sqrt(np.mean(wrap(phase - truth.phase["v"])[truth.mask] ** 2)))

    assert rms(wrapped) > 0.05
    assert rms(lut.correct(wrapped)) < rms(wrapped) / 5


def test_equal_periods_are_refused():
    phase = np.linspace(0, 30, 400).reshape(20, 20)
    with pytest.raises(ValueError, match="periods must differ"):
        disagreement_lut(phase, 18, phase, 18, steps=3)


@pytest.mark.parametrize("gamma", [2.2, 1.0])
def test_decode_diagnoses_a_3_step_three_frequency_capture_from_the_disagreement(gamma, tmp_path):
    s = PRESET.settings.replace(ideal=True, bit_depth=16, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                gamma=gamma)
    ps = sets.three_frequency("v", steps=(3, 3, 3), width=PRESET.rig.projector.width,
                              height=PRESET.rig.projector.height)
    frames, _ = render(Scene([Plane(PRESET.center, (0.1, 0.05, -1.0))]), PRESET.rig, ps, s, progress=False)
    diag = decode(frames, ps, rig=PRESET.rig).info["radiometry"]["v"]["diagnostic"]
    assert diag["method"] == "disagreement" and diag["steps"] == 3
    assert diag["nonlinear"] == (gamma == 2.2)
    assert (diag["fix"] is not None) == (gamma == 2.2)
    if gamma == 2.2:  # against the peak ripple of the true response's 3-step phase-error table
        true_peak = lut_from_response(power_law(2.2), steps=3).amplitude
        assert diag["ripple_rad"] == pytest.approx(true_peak, rel=0.15) and diag["ripple_um"] > 0
