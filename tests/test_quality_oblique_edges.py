"""The projector-edge band at oblique fringe angles: with two non-parallel directions decoded the
band is masked along every projector border (both coordinates known); one oblique direction
masks what its single coordinate allows (:mod:`fringe3d.decode.edges`)."""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from fringe3d.decode import edges
from fringe3d.patterns import sets


SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "border_figures.py"


@pytest.fixture(scope="module")
def figures():
    """scripts/border_figures.py's oblique edge-band figures: tiny rig, a plane wider than the
    projector's light, Gaussian projector defocus 2 px, directions pi/3 -+ pi/4."""
    spec = importlib.util.spec_from_file_location("border_figures", SCRIPT)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.oblique_band_figures()


def test_two_oblique_directions_mask_the_band_along_every_projector_border(figures):
    before, after = figures["before"], figures["after"]  # each direction's own band test / both coordinates
    for d in ("a1", "a2"):
        n_before, rms_before = before[d]["band"]
        assert n_before > 300 and rms_before > 10 * before[d]["inner"][1]   # the band is bad and was kept
        assert after[d]["band"][0] == 0                                      # now masked
        assert after[d]["inner"] == before[d]["inner"]                       # the interior is untouched


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
