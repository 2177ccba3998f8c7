"""Fringe-coordinate conventions (Eq. 2.1-2.2, 2.30-2.34, 1.5) in fringe3d.patterns.conventions."""
import math

import numpy as np
import pytest

from fringe3d.patterns import conventions as C


def test_fringe_coordinate_range_and_phase_round_trip():
    v, u = np.mgrid[0:6, 0:9]
    for a in (0.0, 0.4, math.pi / 2, 2.5):
        w = C.fringe_coordinate(u, v, a)
        lo, hi = C.w_range(a, 9, 6)
        assert np.isclose(w.min(), lo) and np.isclose(w.max(), hi)
        np.testing.assert_allclose(C.phase_to_w(C.w_to_phase(w, 18.0), 18.0), w, atol=1e-12)
        pu, pv = C.point_at_fringe_coordinate(3.0, a)
        assert math.isclose(float(C.fringe_coordinate(pu, pv, a)), 3.0)
    assert C.fringe_coordinate(np.float32([1.0]), np.float32([2.0]), 0.3).dtype == np.float32


def test_projector_point_from_two_directions_and_orders():
    rng = np.random.default_rng(1)
    uv = rng.uniform(0, 800, (50, 2))
    for angles in ([math.pi / 2, 0.0], [0.3 + math.pi / 4, 0.3 - math.pi / 4]):
        w = np.stack([C.fringe_coordinate(uv[:, 0], uv[:, 1], a) for a in angles], 1)
        for solver in ("pinv", "inv"):
            np.testing.assert_allclose(C.projector_coordinates(w, angles, solver=solver), uv, atol=1e-9)
    k_true = rng.integers(0, 40, 100)
    phi = rng.uniform(0, 2 * np.pi, 100)
    coarse = (phi + 2 * np.pi * k_true) / 8.0
    for ties in ("even", "up"):
        np.testing.assert_array_equal(C.coarse_to_fine_order(coarse, phi, 8.0, ties=ties), k_true)
    assert C.beat_period(18.0, 21.0) == 126.0
    with pytest.raises(ValueError):
        C.beat_period(18.0, 18.0)
