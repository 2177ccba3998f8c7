"""The branch-free atan2 used by the fused kernels against numpy.arctan2."""
import numpy as np

from fringe3d.phase._kernels import fast_atan2
from numba import njit


@njit(cache=False)
def _apply(y, x, out):
    for i in range(y.size):
        out[i] = fast_atan2(y[i], x[i])


def test_fast_atan2_matches_numpy_to_1e_7_rad_in_every_quadrant():
    rng = np.random.default_rng(0)
    t = np.linspace(-np.pi, np.pi, 200001)
    r = rng.uniform(1e-3, 1e3, t.size)
    y, x = r * np.sin(t), r * np.cos(t)
    y = np.concatenate([y, [0.0, 0.0, 1.0, -1.0, 0.0]])
    x = np.concatenate([x, [1.0, -1.0, 0.0, 0.0, 0.0]])
    out = np.empty_like(y)
    _apply(y, x, out)
    ref = np.arctan2(y, x)
    d = np.angle(np.exp(1j * (out - ref)))
    assert np.abs(d).max() < 1e-7
    assert out[-1] == 0.0
