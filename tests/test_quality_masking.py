"""Issue 15: edge / mixed-pixel quality bits and the phase-noise estimate, on closed-form data."""
from __future__ import annotations

import math

import numpy as np
import tifffile

from fringe3d.decode import DecodeOptions, Decoded, decode
from fringe3d.decode import edges
from fringe3d.patterns import sets
from fringe3d.patterns.synthetic import frames_from_coordinates
from fringe3d.phase import noise
from fringe3d.phase.psp import wrapped_phase


def test_bits_are_distinct_powers_of_two_and_named():
    bits = [edges.INVALID, edges.EDGE, edges.INCONSISTENT, edges.GRADIENT, edges.MOD_DROP, edges.RIM, edges.ORDER,
            edges.SATURATED]
    assert bits == [1, 2, 4, 8, 16, 32, 64, 128] and set(edges.BITS) == set(bits)


def test_edge_band_marks_coordinates_within_the_margin_of_the_extent():
    w = np.array([[-1.0, 0.0, 1.4, 1.6, 400.0, 797.4, 797.6, np.nan]])
    got = edges.edge_band(w, (-0.5, 799.5), 2.0)
    assert got.tolist() == [[True, True, True, False, False, False, True, False]]


def test_blur_estimate_inverts_the_gaussian_modulation_transfer():
    sigma_b = 1.7
    mtf = [math.exp(-2 * math.pi ** 2 * sigma_b ** 2 / t ** 2) for t in (18.0, 144.0)]
    b_fine, b_coarse = np.full((8, 8), 80 * mtf[0]), np.full((8, 8), 80 * mtf[1])
    assert abs(edges.estimate_blur(b_fine, b_coarse, 18.0, 144.0, np.ones((8, 8), bool)) - sigma_b) < 1e-9
    assert edges.estimate_blur(b_coarse, b_coarse, 18.0, 144.0, np.ones((8, 8), bool)) == 0.0


def test_disagreement_is_the_wrapped_difference_to_the_scaled_absolute_phase():
    phase = np.full((2, 2), 100.0, np.float32)  # float32 maps, as the decoder passes them
    coarse = np.angle(np.exp(1j * (phase * 18 / 144 + 0.3))).astype(np.float32)
    assert np.allclose(edges.disagreement(phase, 18.0, [coarse], [144.0]), 0.3, atol=1e-5)


def test_gradient_and_modulation_tests_mark_a_depth_step_and_a_dim_pixel():
    v, u = np.mgrid[0:20, 0:20].astype(np.float32)
    w = 3.0 * u + 0.01 * v
    w[:, 10:] += 40.0                           # a depth edge between columns 9 and 10
    valid = np.ones(w.shape, bool)
    jump = edges.gradient_jump(w, valid, 4.0, 1.0)
    assert jump[:, 8:12].all() and not jump[:, :8].any() and not jump[:, 12:].any()  # both sides, grown by 1
    mod = np.full(w.shape, 50.0, np.float32)
    mod[5, 5] = 20.0
    drop = edges.modulation_drop(mod, np.full(w.shape, 100.0), valid, 0.5)
    assert drop[5, 5] and drop.sum() == 1


def test_fit_residual_variance_and_phase_sigma_match_monte_carlo():
    rng = np.random.default_rng(0)
    n, sigma, a, b = 9, 2.0, 100.0, 60.0
    shifts = 2 * np.pi * np.arange(n) / n
    phi = rng.uniform(-np.pi, np.pi, (64, 64))
    clean = a + b * np.cos(phi[None] + shifts[:, None, None])
    frames = clean + rng.normal(0, sigma, clean.shape)
    var = noise.fit_residual_variance(frames, range(n), shifts)
    assert abs(math.sqrt(var.mean()) - sigma) < 0.03 * sigma
    pr = wrapped_phase(frames.astype(np.float32), shifts=shifts)
    err = np.angle(np.exp(1j * (pr.phase - phi)))
    predicted = noise.phase_sigma(sigma, pr.modulation, n)
    assert abs(err.std() / np.sqrt(np.mean(predicted ** 2)) - 1) < 0.05


def test_noise_model_recovers_read_plus_shot_noise():
    rng = np.random.default_rng(1)
    avg = rng.uniform(20, 200, (128, 128))
    true_var = 1.5 + 0.05 * avg
    var = true_var * rng.chisquare(6, avg.shape) / 6      # a 9-step residual has 6 degrees of freedom
    # float32 maps, as the decoder passes them
    c0, c1 = noise.fit_noise_model(var.astype(np.float32), avg.astype(np.float32), np.ones(avg.shape, bool))
    assert abs(c0 - 1.5) < 0.3 and abs(c1 - 0.05) < 0.005


def _affine_view(ps):
    """A camera whose view covers the projector's left border (u_p from -8 px)."""
    v, u = np.mgrid[0:48, 0:64].astype(float)
    return -8.0 + 2.5 * u, 100.0 + 2.0 * v


def test_decode_masks_the_border_band_and_reports_it_in_the_quality_map():
    ps = sets.three_frequency("v", width=800, height=600)
    u_p, v_p = _affine_view(ps)
    frames = frames_from_coordinates(ps, u_p, v_p, dtype=np.uint8)
    d = decode(frames, ps, options=DecodeOptions(min_modulation=1.0, edge_margin=3.0))
    q = d.quality["v"]
    assert q.dtype == np.uint8 and np.array_equal(d.mask["v"], q == 0)
    band = u_p < -0.5 + 3.0
    assert (q[band] & edges.EDGE).all() and not (q[~band] & edges.EDGE).any()
    assert d.info["quality"]["v"]["edge_margin"] == 3.0
    off = decode(frames, ps, options=DecodeOptions(min_modulation=1.0, edge_mask=False))
    assert off.mask["v"].all() and not off.quality["v"].any()


def test_decoded_save_load_keeps_quality_and_phase_sigma(tmp_path):
    ps = sets.three_frequency("v", width=800, height=600)
    u_p, v_p = _affine_view(ps)
    frames = frames_from_coordinates(ps, u_p, v_p, dtype=np.uint8)
    d = decode(frames, ps, options=DecodeOptions(min_modulation=1.0))
    d.save(tmp_path)
    back = Decoded.load(tmp_path)
    assert np.array_equal(back.quality["v"], d.quality["v"])
    assert np.array_equal(back.phase_sigma["v"], d.phase_sigma["v"], equal_nan=True)
    tif = tifffile.imread(tmp_path / "quality_v.tif")
    assert tif.dtype == np.uint8 and np.array_equal(tif, d.quality["v"])


def test_noise_model_line_fit_equals_numpy_least_squares():
    rng = np.random.default_rng(7)
    a = rng.uniform(0, 255, (50, 100))
    v = 3.0 + 0.04 * a + rng.normal(0, 0.5, a.shape)
    ones = np.ones(a.shape, bool)
    ref_point = (float(a.mean()), float(v.mean()))
    c0, c1 = noise._line_from_moments(noise.line_moments(a, v, ones, None, 0.0, ref_point), ref_point)
    ref = np.linalg.lstsq(np.stack([np.ones(a.size), a.ravel()], axis=1), v.ravel(), rcond=None)[0]
    assert np.allclose([c0, c1], ref, rtol=1e-10, atol=1e-12)
    flat, y = np.full((1, 10), 4.0), np.arange(10.0)[None]
    assert noise._line_from_moments(noise.line_moments(flat, y, np.ones((1, 10), bool), None, 0.0, (4.0, 0.0)),
                                    (4.0, 0.0)) == (4.5, 0.0)  # constant x: the mean, no slope
