"""Noise-free rendered captures -> decode -> triangulate equals the simulator's truth (< 1 um).

Pinhole rig with camera distortion (and a variant with projector distortion, where only the
least-squares path is exact) and a telecentric rig; the simulator renders analytic sinusoids
(``ideal=True``, float frames), so the only error left is the reconstruction's.
"""
from __future__ import annotations


import numpy as np
import pytest

from fringe3d.decode import DecodeOptions, decode
from fringe3d.patterns import sets
from fringe3d.reconstruct import points_from_decoded
from fringe3d.sim import RenderSettings, render
from fringe3d import sim as sc

from test_triangulate import small_rig, telecentric_rig

SETTINGS = RenderSettings(ideal=True, bit_depth=None, shadows=True)


def patterns(directions=("v",)):
    ps = None
    for d in directions:
        s = sets.hierarchical((18, 90, 300), (9, 3, 3), d, width=256, height=200)
        ps = s if ps is None else ps.concat(s)
    return ps


def reconstruct(rig, scene, method, directions=("v",)):
    ps = patterns(directions)
    frames, truth = render(scene, rig, ps, SETTINGS, progress=False)
    # the triangulation is under test: the method's own mask (the default edge / mixed-pixel
    # masks take ~7 % of these small scenes' pixels, silhouette and projector-border rims)
    dec = decode(frames, ps, options=DecodeOptions(min_modulation=0.02, edge_mask=False))
    return points_from_decoded(dec, rig, method=method), truth


def max_error(P, truth):
    ok = np.isfinite(P[..., 0]) & truth.mask
    assert ok.sum() > 0.98 * truth.mask.sum()
    return float(np.max(np.linalg.norm(P[ok] - truth.xyz[ok], axis=-1)))


PINHOLE_SCENE = sc.Scene([sc.Sphere([5.0, -3.0, 300.0], 40.0), sc.Plane([0.0, 0.0, 380.0], [0.1, 0.0, -1.0])])


@pytest.mark.parametrize("method,directions", [("fast", ("v",)), ("lsq", ("v",)), ("lsq", ("v", "h"))])
def test_pinhole_rig_with_camera_distortion(method, directions):
    P, truth = reconstruct(small_rig(), PINHOLE_SCENE, method, directions)
    assert max_error(P, truth) < 1e-3


def test_projector_distortion_least_squares_exact():
    rig = small_rig(proj_dist=(0.04, -0.01, 0.0004, -0.0002, 0.0))
    P, truth = reconstruct(rig, PINHOLE_SCENE, "lsq")
    assert max_error(P, truth) < 1e-3


def test_telecentric_rig():
    rig = telecentric_rig()
    scene = sc.Scene([sc.Sphere([0.0, 0.0, 100.0], 0.4), sc.Plane([0.0, 0.0, 100.3], [0.2, 0.1, -1.0])])
    for method in ("fast", "lsq"):
        P, truth = reconstruct(rig, scene, method)
        assert max_error(P, truth) < 1e-3
