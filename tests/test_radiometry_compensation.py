"""Issue 25, part 1: a nonlinear projector (gamma 2.2, or a tabulated response with a knee) in the
simulator, its response measured from a grey ramp, and the phase error of captures already taken
compensated by the response LUT, the phase-error LUT (Zhang & Yau 2007) and the self-calibrating
harmonic model, all against the simulator's true phase."""
import numpy as np
import pytest

from fringe3d.patterns import sets
from fringe3d.phase.psp import wrapped_phase
from fringe3d.radiometry import (ResponseLUT, diagnose, estimate_gamma, fit_response, harmonic_lut,
                                 linearise_frames, lut_from_reference, lut_from_response, power_law,
                                 response_phase)
from fringe3d.radiometry.harmonics import harmonic_ratio
from fringe3d.sim import Plane, Scene, presets, render
from fringe3d.sim.virtual_devices import VirtualRigState

PRESET = presets.get("tiny")
PERIOD = 18
_X = np.linspace(0.0, 1.0, 33)
# a measured-looking curve: a square-law toe, then a knee at 75 % input into a flat shoulder
KNEE = tuple(np.where(_X < 0.75, 0.9 * (_X / 0.75) ** 2, 0.9 + 0.1 * (_X - 0.75) / 0.25).tolist())
CURVES = {"gamma2.2": {"gamma": 2.2}, "knee": {"response": KNEE}}


def _true_response(curve: str) -> ResponseLUT:
    return power_law(2.2) if curve == "gamma2.2" else ResponseLUT(_X, np.asarray(KNEE))


def _scene():
    return Scene([Plane(PRESET.center, (0.1, 0.05, -1.0))])


def _capture(steps: int, bit_depth=None, **response):
    s = PRESET.settings.replace(ideal=True, bit_depth=bit_depth, read_noise=0.0, shot_noise=False,
                                camera_blur=0.0, **response)
    ps = sets.phase_shift(PERIOD, steps, "v", width=PRESET.rig.projector.width,
                          height=PRESET.rig.projector.height)
    frames, truth = render(_scene(), PRESET.rig, ps, s, progress=False)
    return frames.astype(np.float64), truth.phase["v"].astype(np.float64), truth.mask


def _rms(phase, truth, mask) -> float:
    return float(np.sqrt(np.mean(np.angle(np.exp(1j * (phase - truth)))[mask] ** 2)))


@pytest.mark.parametrize("curve", sorted(CURVES))
def test_grey_ramp_measures_the_simulators_response_within_one_grey_level(curve):
    s = PRESET.settings.replace(bit_depth=8, **CURVES[curve])
    rig = VirtualRigState(PRESET, _scene(), s)
    proj = PRESET.rig.projector
    levels = np.arange(0, 256, 15)
    frames = []
    for k, lv in enumerate(levels):
        rig.set_image(np.full((proj.height, proj.width), lv, np.uint8))
        frames.append(rig.exposure_image(0.0, k))
    lut = fit_response(levels, np.stack(frames), full_scale=255)
    truth = _true_response(curve).apply(levels / 255.0)
    assert np.max(np.abs(lut.apply(levels / 255.0) - truth)) * 255 <= 1.0
    assert np.all(np.diff(lut.response) >= 0)


@pytest.mark.parametrize("steps", [3, 4])
@pytest.mark.parametrize("curve", sorted(CURVES))
def test_response_and_phase_error_luts_cut_the_phase_error_tenfold(curve, steps):
    frames, truth, mask = _capture(steps, **CURVES[curve])
    raw = _rms(wrapped_phase(frames).phase, truth, mask)
    true_curve = _true_response(curve)
    by_response = _rms(response_phase(frames, true_curve)[0], truth, mask)
    by_linearised = _rms(wrapped_phase(linearise_frames(frames, true_curve)).phase, truth, mask)
    by_lut = _rms(lut_from_response(true_curve, steps=steps).correct(wrapped_phase(frames).phase), truth, mask)
    assert raw > 2e-3                              # the nonlinearity is there to compensate
    assert by_response < raw / 10 and by_linearised < raw / 10 and by_lut < raw / 10


@pytest.mark.parametrize("steps", [3, 4])
def test_phase_error_lut_from_a_reference_region_corrects_the_rest(steps):
    frames, truth, mask = _capture(steps, gamma=2.2)
    phase = wrapped_phase(frames).phase
    left = mask.copy()
    left[:, mask.shape[1] // 2:] = False
    right = mask & ~left
    lut = lut_from_reference(phase, truth, left, bins=128)
    assert _rms(lut.correct(phase), truth, right) < _rms(phase, truth, right) / 10


def test_harmonic_model_from_the_capture_itself_cuts_the_4_step_error_fivefold():
    frames, truth, mask = _capture(4, gamma=2.2)
    phase = wrapped_phase(frames).phase
    lut, est = harmonic_lut(frames, mask)
    assert est.gamma == pytest.approx(2.2, abs=0.05)
    assert _rms(lut.correct(phase), truth, mask) < _rms(phase, truth, mask) / 5


def test_harmonic_model_refuses_three_steps():
    frames, _, _ = _capture(3, gamma=2.2)
    with pytest.raises(ValueError, match="N >= 4"):
        estimate_gamma(frames)


def test_second_harmonic_ratio_matches_the_closed_form_for_gamma_two():
    # (1/2 (1 + cos t))^2 = 3/8 + 1/2 cos t + 1/8 cos 2t  ->  c2 / c1 = 1/4
    assert harmonic_ratio(2.0) == pytest.approx(0.25, abs=1e-12)
    assert harmonic_ratio(1.0) == pytest.approx(0.0, abs=1e-12)


def test_diagnostic_names_gamma_2_2_and_stays_quiet_on_a_linear_projector():
    nonlinear = _capture(4, bit_depth=8, gamma=2.2)
    linear = _capture(4, bit_depth=8, gamma=1.0)
    bad = diagnose(nonlinear[0], nonlinear[2], period=PERIOD)
    good = diagnose(linear[0], linear[2], period=PERIOD)
    assert bad.nonlinear and "nonlinear" in bad.fix and bad.gamma == pytest.approx(2.2, abs=0.1)
    assert bad.ripple_order == 4 and bad.ripple_px == pytest.approx(bad.ripple_rad * PERIOD / (2 * np.pi))
    assert not good.nonlinear and good.fix is None


@pytest.mark.parametrize("steps", [4, 9])
def test_diagnostic_ripple_from_fewer_samples_is_within_its_bound_of_the_default_table(steps):
    # the diagnostic simulates RIPPLE_SAMPLES true phases, not lut_from_response's default 8192
    from fringe3d.radiometry.diagnostic import RIPPLE_SAMPLES
    from fringe3d.radiometry.phase_error import lut_from_response
    from fringe3d.radiometry.response import power_law
    for gamma in (0.7, 1.0, 1.0001, 1.03, 1.1, 1.5, 2.2, 3.0):
        want = lut_from_response(power_law(gamma), steps=steps).amplitude
        got = lut_from_response(power_law(gamma), steps=steps, samples=RIPPLE_SAMPLES).amplitude
        assert abs(got - want) <= 1e-3 * want + 1e-6, (gamma, got, want)


def test_render_settings_reject_a_decreasing_response_table():
    with pytest.raises(ValueError, match="non-decreasing"):
        PRESET.settings.replace(response=(0.0, 0.6, 0.5, 1.0))
