"""The default periods of every pattern set work on the common DMD sizes (issue 13, item 4):
synthetic frames of the whole projector decode with zero fringe-order errors, and the
dissertation's 18/21/144 stays wherever its 1008 px beat covers the projector (ch. 2.2.4)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.commands.patterns import SETS, build_set
from fringe3d.decode import DecodeOptions, decode
from fringe3d.patterns import sets
from fringe3d.patterns.conventions import beat_period, fringe_coordinate
from fringe3d.patterns.manifest import PatternSet
from fringe3d.patterns.synthetic import frames_from_coordinates

SIZES = [(912, 1140), (1024, 768), (1280, 800), (1920, 1080)]
# gray-code / binary-code alone have no phase plan (their decoder is issue 13 item 2); two-frequency
# and hybrid unwrap by the geometric constraint, which needs a rig and a depth range, not a period
# that covers the projector: they are built at every size below but decoded elsewhere.
DECODED_HERE = [s for s in SETS if s not in ("gray-code", "binary-code", "two-frequency", "hybrid")]


def _whole_projector(width: int, height: int):
    """A 64 x 48 camera whose pixels see the projector corner to corner (both edges included)."""
    v_p, u_p = np.meshgrid(np.linspace(0, height - 1, 48), np.linspace(0, width - 1, 64), indexing="ij")
    return u_p, v_p


def _far_corner(width: int, height: int):
    """A 160 x 128 camera seeing the projector's bottom-right corner at 3 projector px per camera px
    (FTP needs fringes the camera resolves; the whole-projector view aliases them)."""
    v, u = np.mgrid[0:128, 0:160].astype(np.float64)
    return width - 1 - 3.0 * (159 - u), height - 1 - 3.0 * (127 - v)


def _build(name: str, width: int, height: int) -> PatternSet:
    # what `fringe3d patterns --set NAME --width W --height H` builds with no other option
    return build_set(name, None, None, "v", 30.0 if name == "optimal-angle" else None, "sinusoid", width, height,
                     None)


@pytest.mark.parametrize("width,height", SIZES)
@pytest.mark.parametrize("name", DECODED_HERE)
def test_default_set_decodes_the_whole_projector_without_fringe_order_errors(name, width, height):
    ps = _build(name, width, height)
    u_p, v_p = (_far_corner if name in ("ftp", "modified-ftp") else _whole_projector)(width, height)
    frames = frames_from_coordinates(ps, u_p, v_p, a=30, b=180, noise=0.5, rng=np.random.default_rng(1),
                                     dtype=np.uint8)
    d = decode(frames, ps, options=DecodeOptions(edge_mask=False))  # the view reaches the DMD border on purpose
    for plan in ps.plans:
        w_true = fringe_coordinate(u_p, v_p, plan.angle)
        w = d.projector_coordinate(plan.direction)
        if plan.method == "none":  # wrapped-phase sets: no fringe order to get wrong
            err = np.angle(np.exp(1j * 2 * np.pi * (w - w_true) / d.period[plan.direction]))
            assert np.sqrt(np.mean(err[16:-16, 16:-16] ** 2)) < 0.05
            continue
        assert d.mask[plan.direction].all(), (name, plan.direction)
        order_errors = np.abs(w - w_true) > d.period[plan.direction] / 2
        assert order_errors.sum() == 0, (name, plan.direction, plan.periods)


@pytest.mark.parametrize("width,height", SIZES)
@pytest.mark.parametrize("name", ["two-frequency", "hybrid", "gray-code", "binary-code"])
def test_default_set_builds_at_every_dmd_size(name, width, height):
    ps = _build(name, width, height)
    assert (ps.width, ps.height) == (width, height) and len(ps) > 0


def test_dissertation_periods_stay_wherever_their_beat_covers_the_projector():
    ps = sets.calibration(912, 1140)  # v spans 911 px (< 1008): unchanged; h spans 1139 px
    periods = {p.direction: p.periods for p in ps.plans}
    assert periods["v"] == (18.0, 21.0, 144.0)
    assert periods["h"][:2] == (18.0, 21.0) and periods["h"][2] != 144.0
    assert sets.calibration(800, 600) == sets.calibration(800, 600, periods=(18.0, 21.0, 144.0))
    for span in (1008.0 * 0.99, 1023.0, 1139.0, 1279.0, 1919.0, 2200.0):
        t1, t2, t3 = sets.default_three_frequency_periods(span)
        t123 = beat_period(beat_period(t1, t2), t3)
        assert t123 > span and (span < 1008 or span <= sets.HEADROOM * t123), span


def test_explicit_dissertation_periods_still_refuse_a_wider_projector():
    with pytest.raises(ValueError, match="1008"):
        sets.three_frequency("v", (18.0, 21.0, 144.0), width=1280, height=800)


def test_patterns_command_writes_the_adapted_calibration_set(tmp_path, capsys):
    rc = main(["patterns", "--set", "calibration", "--width", "1280", "--height", "800", "-o",
               str(tmp_path / "p"), "--json"])
    assert rc == 0
    ps = PatternSet.load(tmp_path / "p")
    t3 = {p.direction: p.periods[2] for p in ps.plans}
    assert t3 == {"v": 138.0, "h": 144.0} and math.isclose(beat_period(126.0, 138.0), 1449.0)
