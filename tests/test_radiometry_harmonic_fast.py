"""Issue 29: the harmonic estimate without a root search or complex temporaries gives the numbers
of the NumPy + brentq implementation it replaced (kept here as the reference): the gamma within
1e-7 of the exact root of ``observed_ratio(gamma) = ratio`` (the old search stopped at 1e-6), the
ratio and its standard error within 1e-12 relative."""
import numpy as np
import pytest
from scipy.optimize import brentq

from fringe3d.radiometry import estimate_gamma
from fringe3d.radiometry.harmonics import GAMMA_RANGE, _ratio_table, gamma_from_ratio, observed_ratio
from reference_implementations import harmonic_bins_reference as _bins
from reference_implementations import harmonic_ratio_reference as _ratio


def _reference_gamma(ratio: float, steps: int, xtol: float) -> float:
    """The former ``gamma_from_ratio``: brentq on ``observed_ratio`` over ``GAMMA_RANGE``."""
    lo, hi = GAMMA_RANGE
    f = lambda g: observed_ratio(g, steps) - ratio  # noqa: E731
    if f(lo) >= 0:
        return lo
    if f(hi) <= 0:
        return hi
    return float(brentq(f, lo, hi, xtol=xtol))


def _reference_estimate(frames, mask, min_modulation=0.0):
    """The former ``estimate_gamma`` fit: complex DFT bins and the masked least squares."""
    f = np.asarray(frames, float)
    s = _bins(f)
    ok = (np.abs(s[0]) > max(min_modulation, 1e-12)) & mask
    return (*_ratio(s, ok, f.shape[0]), int(ok.sum()))


@pytest.mark.parametrize("steps", [4, 5, 6, 8])
def test_gamma_from_ratio_is_the_root_of_the_observed_ratio(steps):
    _, ratios, _ = _ratio_table(steps)
    rng = np.random.default_rng(steps)
    inside = ratios[0] + (ratios[-1] - ratios[0]) * rng.uniform(0.0, 1.0, 12)
    for r in inside:
        g = gamma_from_ratio(r, steps)
        assert g == pytest.approx(_reference_gamma(r, steps, 1e-13), abs=1e-7)
        assert g == pytest.approx(_reference_gamma(r, steps, 1e-6), abs=2e-6)
        assert observed_ratio(g, steps) == pytest.approx(r, abs=1e-9)
    for r in (ratios[0] - 0.1, ratios[0], ratios[-1], ratios[-1] + 0.1):
        assert gamma_from_ratio(r, steps) == _reference_gamma(r, steps, 1e-6)
    with pytest.raises(ValueError, match="finite"):
        gamma_from_ratio(float("nan"), steps)


@pytest.mark.parametrize("steps", [4, 5, 7])
def test_estimate_gamma_matches_the_numpy_fit(steps):
    rng = np.random.default_rng(steps)
    h, w = 48, 64
    phi = np.cumsum(rng.uniform(0.05, 0.3, (h, w)), axis=1)
    albedo = rng.uniform(0.0, 1.0, (h, w))          # some pixels below the modulation floor
    frames = np.stack([20 + 200 * albedo * (0.5 * (1 + np.cos(phi + 2 * np.pi * k / steps))) ** 1.8
                       for k in range(steps)]) + rng.normal(0.0, 1.0, (steps, h, w))
    frames = frames.astype(np.float32)
    mask = rng.uniform(size=(h, w)) > 0.2
    est = estimate_gamma(frames, mask, min_modulation=10.0)
    ratio, sigma, pixels = _reference_estimate(frames, mask, 10.0)
    assert est.pixels == pixels
    assert est.ratio == pytest.approx(ratio, rel=1e-12)
    assert est.ratio_sigma == pytest.approx(sigma, rel=1e-9)
    assert est.gamma == pytest.approx(_reference_gamma(ratio, steps, 1e-13), abs=1e-7)
    assert estimate_gamma(frames).pixels == _reference_estimate(frames, np.ones((h, w), bool))[2]
