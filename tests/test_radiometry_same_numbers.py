"""Issue 29: the radiometry diagnostic's per-call work without its per-call constants gives the same
numbers bit for bit: the simulated phase-error table against its definition (Zhang & Yau's
N-step phase of the response's patterns), the observed harmonic ratio against the vectorised
DFT it was written as, and the compiled ratio pass on integer and float32 frames against the
same pass on their float64 values."""
import numpy as np
import pytest

from fringe3d.phase.psp import default_shifts, lsq_coefficients
from fringe3d.radiometry import lut_from_response, power_law
from fringe3d.radiometry._harmonic_kernel import harmonic_ratio_pass
from fringe3d.radiometry.harmonics import _observed_ratios
from fringe3d.radiometry.phase_error import bin_centres, lut_from_reference


def _table_by_definition(response, shifts, samples: int, bins: int):
    true = bin_centres(samples)
    d = np.asarray(shifts, float)
    patterns = response.apply(0.5 * (1.0 + np.cos(true[None] + d[:, None])))
    _, b, c = np.tensordot(lsq_coefficients(d), patterns, axes=1)
    return lut_from_reference(np.arctan2(-c, b), true, bins=bins)


def _ratios_by_definition(gammas, steps: int, samples: int = 512):
    phi = 2.0 * np.pi * np.arange(samples) / samples
    d = 2.0 * np.pi * np.arange(steps) / steps
    x = 0.5 * (1.0 + np.cos(phi[None, :] + d[:, None]))
    frames = x[None] ** np.asarray(gammas, float)[:, None, None]
    ang = 2.0 * np.pi * np.outer([1, 2], np.arange(steps)) / steps
    s = (np.einsum("mk,gks->gms", np.cos(ang), frames) - 1j * np.einsum("mk,gks->gms", np.sin(ang), frames)) / steps
    s1 = s[:, 0]
    amp = np.abs(s1)
    rot = (np.conj(s1) / amp) ** 2
    if steps == 4:
        model = 2.0 * amp * np.real(1.0 / rot)
        return np.sum(model * s[:, 1].real, axis=1) / np.sum(model ** 2, axis=1)
    return np.sum(amp * np.real(s[:, 1] * rot), axis=1) / np.sum(amp ** 2, axis=1)


@pytest.mark.parametrize("steps", [4, 9])
def test_phase_error_table_is_the_simulated_n_step_phase_bit_for_bit(steps):
    for gamma in (0.7, 1.0001, 2.2):
        for samples, bins in ((2048, 256), (512, 64)):
            for shifts in (default_shifts(steps), default_shifts(steps) + 0.3):
                want = _table_by_definition(power_law(gamma), shifts, samples, bins)
                for _ in range(2):  # the second call reads the cached patterns
                    got = lut_from_response(power_law(gamma), shifts=shifts, samples=samples, bins=bins)
                    assert got.phase.tobytes() == want.phase.tobytes()
                    assert got.error.tobytes() == want.error.tobytes()
    assert lut_from_response(power_law(2.2), steps=steps).error.tobytes() == \
        _table_by_definition(power_law(2.2), default_shifts(steps), 8192, 256).error.tobytes()


@pytest.mark.parametrize("steps", [4, 5, 9])
def test_observed_ratios_are_the_ideal_capture_dft_bit_for_bit(steps):
    gammas = np.array([0.5, 1.0, 1.0001, 2.2, 6.0])
    for _ in range(2):
        assert _observed_ratios(gammas, steps).tobytes() == _ratios_by_definition(gammas, steps).tobytes()


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_ratio_pass_reads_frames_as_their_float64_values(dtype):
    rng = np.random.default_rng(1)
    steps, h, w = 5, 40, 56
    phi = np.cumsum(rng.uniform(0.05, 0.3, (h, w)), axis=1)
    frames = np.stack([20 + 200 * (0.5 * (1 + np.cos(phi + 2 * np.pi * k / steps))) ** 1.8 for k in range(steps)])
    frames = (frames + rng.normal(0.0, 1.0, frames.shape)).astype(dtype)
    mask = rng.uniform(size=(h, w)) > 0.2
    for f, m in ((frames, mask), (frames[:, ::2, 1::3], mask[::2, 1::3])):  # contiguous, and a strided view
        assert harmonic_ratio_pass(f, m, 10.0) == harmonic_ratio_pass(f.astype(np.float64), m, 10.0)


def _wrap(x):
    return np.mod(np.asarray(x, float) + np.pi, 2 * np.pi) - np.pi


def _reference_table(measured, reference, mask=None, bins=256):
    """The numpy form of :func:`lut_from_reference` (wrap, bin, unit-vector mean per bin)."""
    m, r = np.asarray(measured, float), np.asarray(reference, float)
    ok = np.isfinite(m) & np.isfinite(r)
    if mask is not None:
        ok &= np.asarray(mask, bool)
    mw = _wrap(m[ok])
    err = _wrap(mw - r[ok])
    idx = np.minimum(((mw + np.pi) / (2 * np.pi) * bins).astype(int), bins - 1)
    count = np.bincount(idx, minlength=bins)
    s, c = np.bincount(idx, np.sin(err), bins), np.bincount(idx, np.cos(err), bins)
    centres, full = bin_centres(bins), count > 0
    return np.interp(centres, centres[full], np.arctan2(s[full], c[full]), period=2 * np.pi)


def test_table_from_reference_is_the_numpy_wrap_and_bin_bit_for_bit():
    rng = np.random.default_rng(2)
    for k in range(40):
        n = int(rng.integers(500, 4000))
        m, r = rng.uniform(-20, 20, n), rng.uniform(-9, 9, n)
        m[:6] = [np.pi, -np.pi, 0.0, -0.0, 3 * np.pi, -2 * np.pi]   # remainders at the edges
        m[7::11] = np.nan
        mask = rng.random(n) > 0.3 if k % 2 else None
        bins = int(rng.choice([16, 64, 256]))
        got = lut_from_reference(m.reshape(-1, 2)[:, ::-1] if n % 2 == 0 else m, r.reshape(-1, 2)[:, ::-1]
                                 if n % 2 == 0 else r, None if mask is None else
                                 (mask.reshape(-1, 2)[:, ::-1] if n % 2 == 0 else mask), bins=bins)
        want = _reference_table(m.reshape(-1, 2)[:, ::-1] if n % 2 == 0 else m, r.reshape(-1, 2)[:, ::-1]
                                if n % 2 == 0 else r, None if mask is None else
                                (mask.reshape(-1, 2)[:, ::-1] if n % 2 == 0 else mask), bins=bins)
        assert got.error.tobytes() == want.tobytes()
    with pytest.raises(ValueError, match="covers only 1 of 256 phase bins"):
        lut_from_reference(np.zeros(10), np.zeros(10))


def test_table_that_clips_the_pattern_values_gives_the_definitions_table():
    from fringe3d.radiometry.phase_error import ResponseLUT, lut_from_response
    short = ResponseLUT(np.linspace(0.1, 1.0, 50), np.linspace(0.0, 1.0, 50))  # values below 0.1 clip to r(0.1)
    want = _table_by_definition(short, default_shifts(4), 256, 64)
    assert lut_from_response(short, steps=4, samples=256, bins=64).error.tobytes() == want.error.tobytes()


def test_wrap_below_at_and_beyond_the_divisor_is_numpys_mod():
    two_pi = 2 * np.pi
    edges = [two_pi - np.pi, -two_pi - np.pi, np.pi, -np.pi, 0.0, -0.0, 3 * np.pi, -3 * np.pi, 1e300, -1e-300]
    m = np.array([np.nextafter(e, d) for e in edges for d in (-np.inf, np.inf)] + edges)
    r = np.zeros_like(m)
    got = lut_from_reference(np.tile(m, 40), np.tile(r, 40), bins=4)
    assert got.error.tobytes() == _reference_table(np.tile(m, 40), np.tile(r, 40), bins=4).tobytes()
    from fringe3d.radiometry.phase_error import _wrapped_errors
    err, idx = _wrapped_errors(m, r, np.ones(m.size, bool), 4)
    assert err.tobytes() == _wrap(_wrap(m) - r).tobytes()


def test_power_law_inputs_are_the_callers_own_linspace():
    a = power_law(2.2)
    assert a.inputs.tobytes() == np.linspace(0.0, 1.0, 256).tobytes()
    assert a.response.tobytes() == (np.linspace(0.0, 1.0, 256) ** 2.2).tobytes()
    a.inputs[:] = 7.0  # the caller's array: the next table is untouched
    assert power_law(2.2, 256).inputs.tobytes() == np.linspace(0.0, 1.0, 256).tobytes()
    assert power_law(1.5, 3).inputs.tolist() == [0.0, 0.5, 1.0]
