"""binary-defocus experiment (quick variant) against what optics says must happen."""
import math

import numpy as np
import pytest



@pytest.fixture(scope="module")
def result(quick_experiment):
    return quick_experiment("binary-defocus")


def _rms(result, kind, T, sigma):
    for r in result["results"]:
        if r["kind"] == kind and r["period"] == T and r["sigma"] == sigma:
            return r["rms"]
    raise KeyError((kind, T, sigma))


def test_table_covers_every_kind_period_and_blur(result):
    tab = result["tables"][0]
    assert tab["columns"][2:] == ["sigma=1", "sigma=2", "sigma=3", "sigma=4"]
    kinds = {row[0] for row in tab["rows"]}
    assert {"sinusoid", "square", "bayer", "floyd_steinberg"} <= kinds
    assert {row[1] for row in tab["rows"]} == {18, 24, 36, 60}
    assert all(np.isfinite(v) and v >= 0 for row in tab["rows"] for v in row[2:])


def test_sinusoid_error_is_at_the_8bit_quantisation_floor(result):
    # 8-bit rounding: intensity error uniform in +-0.5/255, modulation 1/2 -> phase error well below 3e-3 rad
    for T in (18, 24, 36, 60):
        assert _rms(result, "sinusoid", T, 1.0) < 3e-3


def test_sinusoid_beats_squared_binary_at_small_blur(result):
    for T in (18, 24, 36, 60):
        assert _rms(result, "sinusoid", T, 1.0) < _rms(result, "square", T, 1.0) / 10


def test_squared_binary_error_falls_with_blur_and_grows_with_period(result):
    for T in (18, 24, 36, 60):
        errs = [_rms(result, "square", T, s) for s in (1.0, 2.0, 3.0, 4.0)]
        assert all(a >= b for a, b in zip(errs, errs[1:]))
    at2 = [_rms(result, "square", T, 2.0) for T in (18, 24, 36, 60)]
    assert all(a < b for a, b in zip(at2, at2[1:]))


def test_square_wave_error_matches_its_blurred_harmonics(result):
    # Squared binary sampled on pixels (T/4 whole pixels, the two tie pixels of each period
    # alternating row by row, so after blur each period is a box of T/2 + 1 samples with half-
    # weight ends): harmonic n relative to the fundamental is r_n = sin(n pi/2) cot(n pi/T)/cot(pi/T)
    # (continuous limit +1/5, -1/7). 3-step PSP maps n = 5 (= -1 mod 3) and n = 7 (= +1 mod 3) onto
    # the fundamental; both beat at 6 theta and add: error = (|r5| g5 + |r7| g7) sin(6 theta) with
    # g_n = OTF(n/T)/OTF(1/T) = exp(-2 pi^2 s^2 (n^2 - 1)/T^2); RMS = that / sqrt(2).
    for T, s in ((24, 2.0), (36, 2.0), (60, 3.0), (60, 4.0)):
        r = {n: abs(1 / math.tan(n * math.pi / T)) / (1 / math.tan(math.pi / T)) for n in (5, 7)}
        g = {n: math.exp(-2 * math.pi ** 2 * s ** 2 * (n * n - 1) / T ** 2) for n in (5, 7)}
        predicted = (r[5] * g[5] + r[7] * g[7]) / math.sqrt(2)
        assert _rms(result, "square", T, s) == pytest.approx(predicted, rel=0.05)


def test_dithering_beats_squared_binary_for_wide_fringes(result):
    assert _rms(result, "bayer", 60, 2.0) < _rms(result, "square", 60, 2.0)
    assert _rms(result, "floyd_steinberg", 60, 2.0) < _rms(result, "square", 60, 2.0)
    assert all(result["goals"].values())
