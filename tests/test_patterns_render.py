"""Rendered patterns against their closed forms (Eq. 2.1-2.2)."""
import math

import numpy as np
import pytest

from fringe3d.patterns import render_frame, render_set, sinusoid_value, sets
from fringe3d.patterns.manifest import FrameSpec


def _w(angle, width, height):
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    return v * math.cos(angle) + u * math.sin(angle)


@pytest.mark.parametrize("angle,period,shift", [(0.0, 18.0, 0.0), (math.pi / 2, 21.5, 1.0), (0.7, 13.37, -2.0),
                                                (2.5, 40.0, 3.0)])
def test_sinusoid_frame_matches_closed_form_at_any_angle_and_period(angle, period, shift):
    spec = FrameSpec(kind="sinusoid", direction="x", angle=angle, period=period, shift=shift, steps=1)
    img = render_frame(spec, 97, 61)
    assert img.shape == (61, 97) and img.dtype == np.float32
    ref = 0.5 * (1 + np.cos(2 * np.pi * _w(angle, 97, 61) / period + shift))
    np.testing.assert_allclose(img, ref, atol=1e-6)


def test_sinusoid_value_is_continuous_in_projector_coordinates():
    spec = FrameSpec(kind="sinusoid", direction="v", angle=math.pi / 2, period=18, shift=0.5, steps=1)
    u = np.array([0.25, 10.5, 100.125])
    v = np.array([3.0, 7.5, 0.0])
    np.testing.assert_allclose(sinusoid_value(spec, u, v), 0.5 * (1 + np.cos(2 * np.pi * u / 18 + 0.5)))


def test_n_step_phase_of_rendered_set_equals_fringe_coordinate_phase():
    # Independent least-squares phase (Eq. 2.4, written out here) of the rendered frames.
    ps = sets.phase_shift(23.3, 5, "a", angle=1.1, width=64, height=48)
    frames = np.stack([render_frame(f, 64, 48) for f in ps.frames]).astype(np.float64)
    d = np.array([f.shift for f in ps.frames])
    assert np.allclose(d, 2 * np.pi * np.arange(5) / 5)
    phi = np.arctan2(-np.tensordot(np.sin(d), frames, 1), np.tensordot(np.cos(d), frames, 1))
    truth = 2 * np.pi * _w(1.1, 64, 48) / 23.3
    err = np.angle(np.exp(1j * (phi - truth)))
    assert np.abs(err).max() < 1e-5


def test_render_set_8bit_rounds_to_nearest_level():
    ps = sets.phase_shift(18, 3, "h", width=40, height=30)
    out = render_set(ps)
    assert out.shape == (3, 30, 40) and out.dtype == np.uint8
    ideal = np.stack([render_frame(f, 40, 30) for f in ps.frames]) * 255
    assert np.abs(out - ideal).max() <= 0.5 + 1e-3
    assert out.max() == 255 and out.min() == 0


@pytest.mark.parametrize("kind", ["square", "bayer", "floyd_steinberg", "area_modulated", "pwm"])
def test_binary_kinds_give_exactly_zero_or_one_and_one_bit_sets_give_0_255(kind):
    ps = sets.phase_shift(24, 4, "v", kind=kind, width=96, height=40)
    assert ps.bit_depth == 1
    for f in ps.frames:
        img = render_frame(f, 96, 40)
        assert set(np.unique(img)) <= {0.0, 1.0}
    assert set(np.unique(render_set(ps))) == {0, 255}


@pytest.mark.parametrize("kind", ["square", "bayer", "floyd_steinberg", "area_modulated", "pwm"])
def test_binary_kinds_keep_the_fundamental_phase_of_the_sinusoid(kind):
    # The period-T Fourier component along w of a binary pattern has the sinusoid's phase.
    period, width, height = 24.0, 240, 64
    for shift in (0.0, 2.0):
        spec = FrameSpec(kind=kind, direction="v", angle=math.pi / 2, period=period, shift=shift, steps=1)
        img = render_frame(spec, width, height).astype(np.float64)
        u = np.arange(width)
        c = (img.mean(axis=0) * np.exp(-2j * np.pi * u / period)).mean()
        assert abs(np.angle(c) - shift) < 0.08, (kind, shift, np.angle(c))
        assert abs(c) > 0.1  # ideal sinusoid has 0.25; square wave 1/pi = 0.318


def test_squared_binary_is_on_where_sinusoid_exceeds_half():
    spec = FrameSpec(kind="square", direction="v", angle=math.pi / 2, period=18.0, shift=0.3, steps=1)
    img = render_frame(spec, 180, 4)
    s = 0.5 * (1 + np.cos(2 * np.pi * np.arange(180) / 18 + 0.3))
    np.testing.assert_array_equal(img[0], (s > 0.5).astype(np.float32))
    assert img.mean() == pytest.approx(0.5)


def test_squared_binary_with_even_half_period_alternates_edge_pixels_and_keeps_phase():
    # T = 24: stripe edges fall on pixel centres; the tie pixels alternate row by row
    spec = FrameSpec(kind="square", direction="v", angle=math.pi / 2, period=24.0, steps=1)
    img = render_frame(spec, 240, 8).astype(np.float64)
    assert np.all(img.mean(axis=1) == 0.5)
    u = np.arange(240)
    c = (img.mean(axis=0) * np.exp(-2j * np.pi * u / 24)).mean()
    assert abs(np.angle(c)) < 1e-9


def test_area_modulation_matches_sinusoid_on_average_along_stripes():
    spec = FrameSpec(kind="area_modulated", direction="v", angle=math.pi / 2, period=30.0, steps=1)
    img = render_frame(spec, 120, 64, area_cell=4)
    s = 0.5 * (1 + np.cos(2 * np.pi * np.arange(120) / 30))
    # each column has 64/4 whole cells, so its on-fraction is the sinusoid quantised to 1/4
    assert np.abs(img.mean(axis=0) - s).max() <= 0.125 + 1e-9


def test_white_and_black_frames():
    assert render_frame(FrameSpec(kind="white", role="texture"), 5, 4).min() == 1.0
    assert render_frame(FrameSpec(kind="black", role="reference"), 5, 4).max() == 0.0
