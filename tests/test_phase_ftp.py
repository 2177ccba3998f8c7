"""Fourier transform profilometry (Eq. 4.1-4.7) against closed-form fringes."""
import math

import numpy as np
import pytest

from fringe3d.phase.ftp import (BORDER_1E4_PX, BORDER_PX, NONINTEGER_BORDER_ERROR, detect_carrier, ftp_phase,
                                modified_ftp_phase)

H, W = 128, 160
V, U = np.mgrid[0:H, 0:W].astype(np.float64)

# carriers with a whole number of periods across the image: (f_v, f_u) cycles/pixel
INTEGER_CARRIERS = [(0.0, 10 / W), (8 / H, 0.0), (4 / H, 6 / W), (-5 / H, 7 / W)]


def wrap(x):
    return np.angle(np.exp(1j * x))


def carrier_phase(fv, fu, offset=0.4):
    return 2 * np.pi * (fv * V + fu * U) + offset


@pytest.mark.parametrize("window", ["hanning", "circular"])
@pytest.mark.parametrize("carrier", INTEGER_CARRIERS)
def test_ftp_exact_for_whole_periods_at_any_angle(window, carrier):
    phi = carrier_phase(*carrier)
    angle = math.atan2(carrier[1], carrier[0]) % math.pi     # manifest angle in [0, pi)
    phase, mod = ftp_phase(100 + 60 * np.cos(phi), window=window, angle=angle)
    assert np.abs(wrap(phase - phi)).max() < 1e-4
    assert np.abs(mod - 60).max() < 1e-3


@pytest.mark.parametrize("carrier", INTEGER_CARRIERS)
def test_carrier_detection_finds_the_lobe_along_the_fringe_coordinate(carrier):
    phi = carrier_phase(*carrier)
    angle = math.atan2(carrier[1], carrier[0]) % math.pi
    fv, fu = detect_carrier(100 + 60 * np.cos(phi), angle=angle)
    sign = 1 if carrier[0] * math.cos(angle) + carrier[1] * math.sin(angle) > 0 else -1
    assert np.allclose((fv, fu), (sign * carrier[0], sign * carrier[1]), atol=1e-9)


@pytest.mark.parametrize("window", ["hanning", "circular"])
def test_ftp_error_away_from_border_for_non_integer_periods(window):
    """Leakage from the image edges: the stated error bound holds beyond BORDER_PX."""
    b = BORDER_PX
    for period, angle in ((16.3, math.pi / 2), (17.7, 0.6), (20.0, 2.5)):
        phi = 2 * np.pi * (V * math.cos(angle) + U * math.sin(angle)) / period
        phase, _ = ftp_phase(100 + 60 * np.cos(phi), window=window, angle=angle)
        err = np.abs(wrap(phase - phi))
        assert err[b:H - b, b:W - b].max() < NONINTEGER_BORDER_ERROR[window]
        assert err.max() > NONINTEGER_BORDER_ERROR[window]     # the border really is worse


def test_hanning_ftp_below_1e_4_rad_beyond_stated_border_for_any_carrier():
    h, w = 512, 640
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    b = BORDER_1E4_PX
    for period, angle in ((16.3, math.pi / 2), (17.7, 0.6), (20.0, 2.5), (25.1, 1.2)):
        phi = 2 * np.pi * (v * math.cos(angle) + u * math.sin(angle)) / period
        phase, _ = ftp_phase(100 + 60 * np.cos(phi), window="hanning", angle=angle)
        err = np.abs(wrap(phase - phi))
        assert err[b:h - b, b:w - b].max() < 1e-4
        assert err[b // 4:h - b // 4, b // 4:w - b // 4].max() > 1e-4   # the border is needed


def test_modified_ftp_removes_background_and_is_exact_for_whole_periods():
    fv, fu = 4 / H, 6 / W
    phi = carrier_phase(fv, fu) + 0.8 * np.exp(-((V - 64) ** 2 + (U - 80) ** 2) / (2 * 30.0 ** 2))
    background = 100 + 40 * np.exp(-((V - 30) ** 2 + (U - 40) ** 2) / 800.0)   # strong, uneven DC
    i1 = background + 50 * np.cos(phi)
    i2 = background - 50 * np.cos(phi)
    angle = math.atan2(fu, fv)
    phase2, mod2 = modified_ftp_phase(i1, i2, angle=angle)
    phase1, _ = ftp_phase(i1, window="circular", angle=angle)
    e2 = np.abs(wrap(phase2 - phi))
    e1 = np.abs(wrap(phase1 - phi))
    assert np.sqrt(np.mean(e2 ** 2)) < 0.5 * np.sqrt(np.mean(e1 ** 2))
    assert np.sqrt(np.mean(e2 ** 2)) < 5e-3
    assert np.median(np.abs(mod2 - 50)) < 0.5


def test_ftp_rejects_bad_input():
    with pytest.raises(ValueError, match="no fringe carrier"):
        ftp_phase(np.full((32, 32), 7.0))
    with pytest.raises(ValueError, match="unknown FTP window"):
        ftp_phase(100 + 50 * np.cos(2 * np.pi * U / 16), window="gauss")
    with pytest.raises(ValueError, match="one shape"):
        modified_ftp_phase(np.zeros((4, 4)), np.zeros((4, 5)))
