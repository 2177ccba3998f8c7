"""Projector defocus models (Eq. 2.22-2.26) against their closed forms and against each other."""
import numpy as np
import pytest
from scipy.ndimage import convolve
from scipy.special import j1

from fringe3d.optics.defocus import (blur_pattern, defocus_size_at, gaussian_otf, hopkins_otf, otf,
                                     psf_kernel)

T = 18  # squared binary period (projector px)


def square_wave(width=T * 16, height=8):
    """Squared binary pattern: 1 where cos(2 pi u / T) > 0 (periodic in the image width)."""
    u = np.arange(width)
    row = (np.cos(2 * np.pi * u / T) > 0).astype(float)
    return np.tile(row, (height, 1))


def harmonic(row, k, periods):
    """Complex Fourier coefficient of harmonic ``k`` of a row spanning ``periods`` fringe periods."""
    return np.fft.rfft(row)[k * periods]


def test_gaussian_otf_closed_form_values():
    f = np.array([0.0, 0.05, 0.1])
    assert np.allclose(gaussian_otf(f, 2.0), np.exp(-2 * np.pi**2 * 4 * f**2))
    assert gaussian_otf(0.3, 0.0) == 1.0


def test_hopkins_otf_is_2J1a_over_a_with_unit_dc():
    s = np.array([0.0, 0.01, 0.05, 0.1])
    omega, lam = 0.8, 1.0
    a = 4 * np.pi * omega * s / lam
    expect = np.where(a == 0, 1.0, 2 * j1(np.where(a == 0, 1, a)) / np.where(a == 0, 1, a))
    assert np.allclose(hopkins_otf(s, omega, lam), expect)
    # only omega / lambda matters
    assert np.allclose(hopkins_otf(s, 400e-6, 500e-6), hopkins_otf(s, 0.8, 1.0))


@pytest.mark.parametrize("sigma", [0.5, 1.0, 2.0, 3.0])
def test_gaussian_blur_lowers_square_wave_harmonics_as_closed_form(sigma):
    img = square_wave()
    periods = img.shape[1] // T
    blurred = blur_pattern(img, "gaussian", sigma, pad=0)
    for k in (1, 3, 5):
        ratio = harmonic(blurred[4], k, periods) / harmonic(img[4], k, periods)
        expect = np.exp(-2 * np.pi**2 * sigma**2 * (k / T) ** 2)
        assert abs(ratio.real - expect) <= 0.05 * expect
        assert abs(ratio.imag) < 1e-9  # a real OTF does not move the phase (Eq. 2.27-2.29)


@pytest.mark.parametrize("omega", [0.2, 0.4, 0.6])
def test_hopkins_blur_lowers_square_wave_harmonics_as_2J1a_over_a(omega):
    img = square_wave()
    periods = img.shape[1] // T
    blurred = blur_pattern(img, "hopkins", omega, pad=0)
    for k in (3, 5):
        a = 4 * np.pi * omega * (k / T)
        expect = 2 * j1(a) / a
        ratio = harmonic(blurred[4], k, periods) / harmonic(img[4], k, periods)
        assert abs(ratio.real - expect) <= 0.05 * abs(expect)


def test_padded_blur_matches_periodic_blur_away_from_the_borders():
    img = square_wave(width=T * 20)
    per = blur_pattern(img, "gaussian", 2.0, pad=0)
    pad = blur_pattern(img[:, :T * 20 - 7], "gaussian", 2.0)  # not a whole number of periods
    assert np.allclose(per[:, 20:T * 20 - 30], pad[:, 20:T * 20 - 30], atol=1e-6)


@pytest.mark.parametrize("model,size", [("gaussian", 1.5), ("hopkins", 1.2)])
def test_psf_kernel_convolution_matches_otf_blur(model, size):
    """Spatial convolution with the PSF and the frequency-domain OTF give the same image."""
    rng = np.random.default_rng(0)
    img = rng.random((64, 64))
    k = psf_kernel(model, size)
    assert k.sum() == pytest.approx(1.0)
    assert np.allclose(k, k.T) and np.allclose(k, k[::-1])  # circular symmetry
    spatial = convolve(img, k, mode="wrap")
    freq = blur_pattern(img, model, size, pad=0)
    # white noise in [0, 1] is the worst case; the kernel integrates each pixel's area
    # (the OTF is point-sampled), and the disc's edge is pixel-quantised
    tol = 0.01 if model == "gaussian" else 0.04
    assert np.abs(spatial - freq).max() < tol


def test_hopkins_psf_is_a_disc_of_radius_two_omega():
    k = psf_kernel("hopkins", 2.0)  # radius 4 px
    c = k.shape[0] // 2
    assert k[c, c] > 0 and k[c, c + 3] == pytest.approx(k[c, c])
    assert k[c, c + 5] == 0 and k[c + 4, c + 4] == 0


def test_defocus_grows_linearly_from_the_focal_plane():
    d = np.array([300.0, 400.0, 450.0])
    assert np.allclose(defocus_size_at(d, 1.0, 400.0, 0.01), [2.0, 1.0, 1.5])
    assert np.allclose(defocus_size_at(d, 1.0, None, 0.01), 1.0)


def test_bad_defocus_input_is_rejected():
    with pytest.raises(ValueError, match="unknown defocus model"):
        blur_pattern(np.zeros((4, 4)), "bokeh", 1.0)
    with pytest.raises(ValueError, match="sigma"):
        gaussian_otf(0.1, -1.0)
    with pytest.raises(ValueError, match="2D image"):
        blur_pattern(np.zeros(4), "gaussian", 1.0)
    assert np.allclose(otf([0.1], "none", 3.0), 1.0)
