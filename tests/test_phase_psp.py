"""Wrapped phase by phase shifting (Eq. 1.4, 2.4) against closed-form synthetic fringes."""
import math

import numpy as np
import pytest

from fringe3d.phase.psp import default_shifts, lsq_coefficients, three_step, wrapped_phase
from reference_implementations import wrapped_phase_reference


def fringes(phi, shifts, a=120.0, b=80.0, sigma=0.0, rng=None):
    """Closed form I_k = A + B cos(phi + delta_k) (+ Gaussian noise), float64 (N, H, W)."""
    f = np.stack([a + b * np.cos(phi + d) for d in shifts])
    if sigma:
        f = f + rng.normal(0.0, sigma, f.shape)
    return f


def wrap(x):
    return np.angle(np.exp(1j * x))


@pytest.fixture(scope="module")
def phi():
    rng = np.random.default_rng(1)
    v, u = np.mgrid[0:128, 0:160]
    return wrap(2 * np.pi * (u * 0.37 + v * 0.11) / 7.3 + rng.uniform(-np.pi, np.pi, (128, 160)))


@pytest.mark.parametrize("n", range(3, 13))
def test_n_step_phase_matches_closed_form(phi, n):
    r = wrapped_phase(fringes(phi, default_shifts(n)))
    assert np.abs(wrap(r.phase - phi)).max() < 1e-4
    assert np.abs(r.average - 120.0).max() < 1e-3
    assert np.abs(r.modulation - 80.0).max() < 1e-3


def test_arbitrary_shifts_solved_by_least_squares(phi):
    shifts = [0.1, 1.3, 2.0, 4.4, 5.1]
    r = wrapped_phase(fringes(phi, shifts), shifts=shifts)
    assert np.abs(wrap(r.phase - phi)).max() < 1e-4
    assert np.abs(r.modulation - 80.0).max() < 1e-3
    ref = wrapped_phase_reference(fringes(phi, shifts), shifts=shifts)
    assert np.abs(wrap(ref.phase - phi)).max() < 1e-4


def test_three_step_formula_uses_minus_zero_plus_two_thirds_pi(phi):
    i1, i2, i3 = fringes(phi, [-2 * np.pi / 3, 0.0, 2 * np.pi / 3])
    assert np.abs(wrap(three_step(i1, i2, i3) - phi)).max() < 1e-12
    # the manifest's 0, 2pi/3, 4pi/3 order is the same formula on (I3, I1, I2)
    j1, j2, j3 = fringes(phi, default_shifts(3))
    assert np.abs(wrap(three_step(j3, j1, j2) - phi)).max() < 1e-12
    assert np.abs(wrap(wrapped_phase(np.stack([j1, j2, j3])).phase - phi)).max() < 1e-4


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_numba_kernel_equals_numpy_reference(dtype):
    rng = np.random.default_rng(2)
    hi = 255 if dtype == np.uint8 else 4095
    for n in (3, 4, 9):
        f = rng.integers(0, hi + 1, (n, 96, 112)).astype(dtype)
        fast = wrapped_phase(f)
        ref = wrapped_phase_reference(f)
        ok = ref.modulation > 1e-3 * hi
        assert np.abs(wrap(fast.phase - ref.phase))[ok].max() < 1e-5
        assert np.allclose(fast.modulation, ref.modulation, rtol=1e-5, atol=1e-4 * hi)
        assert np.allclose(fast.average, ref.average, rtol=1e-6, atol=1e-4)


@pytest.mark.parametrize("n", [3, 4, 9])
def test_phase_noise_matches_sqrt_2_over_n_sigma_over_b(n):
    rng = np.random.default_rng(10 + n)
    v, u = np.mgrid[0:320, 0:320]
    phi = wrap(2 * np.pi * (u + 0.3 * v) / 21.0)
    sigma, b = 1.5, 80.0
    r = wrapped_phase(fringes(phi, default_shifts(n), b=b, sigma=sigma, rng=rng))
    err = wrap(r.phase - phi)
    assert err.size >= 1e5
    expected = math.sqrt(2.0 / n) * sigma / b
    assert abs(err.std() / expected - 1.0) < 0.10


def test_index_selects_frames_without_copying():
    phi = np.full((4, 5), 0.7)
    f = np.concatenate([np.zeros((2, 4, 5)), fringes(phi, default_shifts(4))])
    r = wrapped_phase(f, index=[2, 3, 4, 5])
    assert np.allclose(r.phase, 0.7, atol=1e-6)


def test_saturation_map_flags_pixels_at_max_code():
    f = np.full((3, 4, 4), 100, np.uint8)
    f[1, 2, 3] = 255
    _, sat = wrapped_phase(f, saturation_level=255, return_saturated=True)
    assert sat.sum() == 1 and sat[2, 3]


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(ValueError, match="at least 3"):
        lsq_coefficients([0.0, np.pi])
    with pytest.raises(ValueError, match="cannot separate"):
        lsq_coefficients([0.0, np.pi, 0.0, np.pi])
    with pytest.raises(ValueError, match="one shift per frame"):
        wrapped_phase(np.zeros((4, 3, 3)), shifts=[0, 1, 2])
    with pytest.raises(ValueError, match="different shapes"):
        wrapped_phase([np.zeros((3, 3)), np.zeros((3, 4)), np.zeros((3, 3))])
    with pytest.raises(ValueError, match=r"\(N, H, W\)"):
        wrapped_phase(np.zeros((3, 3)))
