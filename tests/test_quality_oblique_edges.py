"""The projector-edge band at oblique fringe angles: with two non-parallel directions decoded the
band is masked along every projector border (both coordinates known); one oblique direction
masks what its single coordinate allows (:mod:`fringe3d.decode.edges`)."""
from __future__ import annotations

import math

import numpy as np
import pytest

import fringe3d.decode.decoder as decoder
from fringe3d.decode import DecodeOptions, decode, edges
from fringe3d.patterns import sets
from fringe3d.sim import presets, render
from fringe3d.sim.primitives import Plane
from fringe3d.sim.scene import Scene


@pytest.fixture(scope="module")
def oblique_capture():
    """Tiny rig, a plane wider than the projector's light (its top-left border in view), a blurred
    projector (Gaussian defocus 2 px) and two fringe directions at pi/3 -+ pi/4."""
    p = presets.get("tiny")
    ps = sets.optimal_angle_calibration(math.pi / 3, width=p.rig.projector.width, height=p.rig.projector.height)
    s = p.settings.replace(defocus="gaussian", defocus_size=2.0, seed=1)
    frames, truth = render(Scene([Plane((0, 0, 700.0), (0, 0, -1.0), albedo=0.8)]), p.rig, ps, s, progress=False)
    return p.rig, ps, frames, truth


def _figures(ps, d, truth):
    """Per direction: (kept pixels, RMS of the w error (px)) in the true border band and inside."""
    up, vp = truth.up, truth.vp
    m = d.info["quality"]["a1"]["edge_margin"]
    lit = np.isfinite(up)
    band = edges.border_band(up, vp, ps.width, ps.height, m) & lit
    inner = ~edges.border_band(up, vp, ps.width, ps.height, m + 3) & lit
    out = {}
    for p in ps.plans:
        err = d.projector_coordinate(p.direction) - (vp * math.cos(p.angle) + up * math.sin(p.angle))
        for name, sel in (("band", band), ("inner", inner)):
            v = err[sel & d.mask[p.direction]]
            out[p.direction, name] = (v.size, float(np.sqrt(np.mean(v ** 2))) if v.size else 0.0)
    return out


def test_two_oblique_directions_mask_the_band_along_every_projector_border(oblique_capture, monkeypatch):
    _, ps, frames, truth = oblique_capture
    after = _figures(ps, decode(frames, ps, options=DecodeOptions(bit_depth=8)), truth)
    monkeypatch.setattr(decoder, "mask_projector_border", lambda *a: None)  # each direction's own band only
    before = _figures(ps, decode(frames, ps, options=DecodeOptions(bit_depth=8)), truth)
    for d in ("a1", "a2"):
        n_before, rms_before = before[d, "band"]
        assert n_before > 300 and rms_before > 10 * before[d, "inner"][1]   # the band is bad and was kept
        assert after[d, "band"][0] == 0                                      # now masked
        assert after[d, "inner"] == before[d, "inner"]                       # the interior is untouched


def test_projector_position_inverts_the_fringe_coordinates_of_two_directions():
    rng = np.random.default_rng(0)
    u, v = rng.uniform(-5, 900, (2, 50))
    a1, a2 = 0.3, 1.9
    uu, vv = edges.projector_position(v * math.cos(a1) + u * math.sin(a1), a1, v * math.cos(a2) + u * math.sin(a2), a2)
    assert np.allclose(uu, u, atol=1e-3) and np.allclose(vv, v, atol=1e-3)
    with pytest.raises(ValueError, match="parallel"):
        edges.projector_position(u, 0.4, v, 0.4)


@pytest.mark.parametrize("angle", [0.0, math.pi / 2, math.pi / 4, 1.2])
def test_one_direction_band_is_where_the_line_of_constant_w_misses_the_inset_projector(angle):
    """w outside the extent shrunk by margin (|cos a| + |sin a|) <=> every projector pixel with that
    w lies within margin of a border (checked by sampling the line across the projector)."""
    W, H, margin = 64, 48, 3.0
    f = edges.oblique_factor(angle)
    lo, hi = (x for x in sets.w_range_option(angle, W, H))
    w = np.linspace(lo - 2, hi + 2, 301)
    band = edges.edge_band(w, (lo - 0.5 * f, hi + 0.5 * f), margin * f)
    t = np.linspace(-2000, 2000, 400001)  # the line w = const, parametrised along the fringe
    c, s = math.cos(angle), math.sin(angle)
    for wi, b in zip(w, band):
        u, v = wi * s - t * c, wi * c + t * s
        inside = (u >= -0.5) & (u <= W - 0.5) & (v >= -0.5) & (v <= H - 0.5)
        if not inside.any():
            assert b
            continue
        assert b == bool(edges.border_band(u[inside], v[inside], W, H, margin).all()), wi
