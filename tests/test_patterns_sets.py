"""Pattern-set builders: frame fields and plans the decoder relies on."""
import math

import numpy as np
import pytest

from fringe3d.patterns import sets
from fringe3d.patterns.manifest import PatternSet


def test_three_frequency_is_9_step_18_plus_3_step_21_plus_3_step_144_with_beats():
    ps = sets.three_frequency("v", width=800, height=600)
    assert len(ps) == 15
    assert [f.period for f in ps.frames] == [18.0] * 9 + [21.0] * 3 + [144.0] * 3
    assert all(f.angle == pytest.approx(math.pi / 2) and f.direction == "v" and f.role == "phase" for f in ps.frames)
    for g, n in (("v/T18", 9), ("v/T21", 3), ("v/T144", 3)):
        idx = ps.indices(group=g)
        assert len(idx) == n
        assert [ps.frames[i].step for i in idx] == list(range(n))
        assert all(ps.frames[i].steps == n for i in idx)
        np.testing.assert_allclose([ps.frames[i].shift for i in idx], 2 * np.pi * np.arange(n) / n)
    plan = ps.plan("v")
    assert plan.method == "heterodyne" and plan.periods == (18.0, 21.0, 144.0)
    (a, b, t12), (c, d, t123) = plan.options["beats"]
    assert t12 == pytest.approx(126.0) and t123 == pytest.approx(1008.0)


def test_three_frequency_rejects_a_projector_wider_than_the_equivalent_period():
    with pytest.raises(ValueError, match="1008"):
        sets.three_frequency("v", (18.0, 21.0, 144.0), width=1280, height=800)


def test_calibration_set_is_white_plus_15_per_direction():
    ps = sets.calibration(800, 600)
    assert len(ps) == 31
    assert ps.frames[0].kind == "white" and ps.frames[0].role == "texture"
    assert ps.directions() == ["v", "h"]
    assert [p.method for p in ps.plans] == ["heterodyne", "heterodyne"]
    assert {f.angle for f in ps.frames if f.direction == "h"} == {0.0}


def test_optimal_angle_calibration_uses_alpha_plus_minus_quarter_pi():
    alpha = math.radians(150)
    ps = sets.optimal_angle_calibration(alpha, 600, 400)
    assert len(ps) == 31
    a1 = [f.angle for f in ps.frames if f.direction == "a1"]
    a2 = [f.angle for f in ps.frames if f.direction == "a2"]
    assert len(a1) == len(a2) == 15
    assert a1 == pytest.approx([alpha - math.pi / 4] * 15)
    assert a2 == pytest.approx([alpha + math.pi / 4 - math.pi] * 15)  # taken modulo pi
    assert ps.plan("a2").options["alpha_opt"] == pytest.approx(alpha)


def test_two_frequency_hybrid_ftp_plans_and_frame_counts():
    tf = sets.two_frequency(18, 144)
    assert len(tf) == 6 and tf.plan("v").method == "two_frequency_geometric"
    assert tf.plan("v").periods == (18.0, 144.0)
    hy = sets.hybrid(18, 144)
    assert len(hy) == 4 and hy.plan("v").method == "hybrid"
    assert hy.frames[-1].period == 18.0 and hy.frames[-1].steps == 1
    assert [f.period for f in hy.frames[:3]] == [144.0] * 3
    ft = sets.ftp(20)
    assert len(ft) == 1 and ft.plan("v").options["phase"] == "ftp"
    mf = sets.modified_ftp(20)
    assert [f.shift for f in mf.frames] == [0.0, pytest.approx(math.pi)]
    assert mf.plan("v").options["phase"] == "modified_ftp"


def test_psp_with_gray_code_has_phase_then_code_frames_of_the_same_period():
    ps = sets.psp_with_gray_code(18, 4, "h", width=300, height=200)
    roles = [f.role for f in ps.frames]
    assert roles[:4] == ["phase"] * 4 and set(roles[4:]) == {"code"}
    assert {f.period for f in ps.frames if f.role == "phase"} == {18.0}
    plan = ps.plan("h")
    assert plan.method == "gray_code" and plan.options["phase"] == "psp"
    assert plan.options["code_period"] == 9.0  # half-period (complementary) code by default
    assert {f.period for f in ps.frames if f.role == "code"} == {9.0}
    assert 2 ** plan.options["bits"] * 9 >= 200


def test_hierarchical_requires_a_coarsest_period_covering_the_projector():
    ps = sets.hierarchical((16, 128, 1024), (4, 3, 3), "v", width=800, height=600)
    assert ps.plan("v").periods == (16.0, 128.0, 1024.0) and len(ps) == 10
    with pytest.raises(ValueError, match="coarsest"):
        sets.hierarchical((16, 128), 3, "v", width=800, height=600)


def test_one_bit_output_needs_a_binary_kind():
    with pytest.raises(ValueError, match="binary kind"):
        sets.phase_shift(18, 3, kind="sinusoid", bit_depth=1)
    assert sets.phase_shift(18, 3, kind="bayer").bit_depth == 1


def test_unknown_direction_without_angle_is_rejected():
    with pytest.raises(ValueError, match="explicit angle"):
        sets.phase_shift(18, 3, direction="diag")


def test_manifest_json_round_trip(tmp_path):
    ps = sets.calibration(400, 300).concat(sets.psp_with_gray_code(20, 3, "v", width=400, height=300), name="x")
    path = ps.save(tmp_path)
    assert PatternSet.load(path) == ps


def test_half_period_code_refines_the_full_period_gray_code_by_one_bit():
    from fringe3d.patterns import codes, render_frame
    full = sets.psp_with_gray_code(20, 3, "v", width=320, height=8, code=sets.CodeFrames(period=20))
    half = sets.psp_with_gray_code(20, 3, "v", width=320, height=8)
    nf, nh = full.plan("v").options["bits"], half.plan("v").options["bits"]
    assert nh == nf + 1 and half.plan("v").options["code_period"] == 10
    bits = np.stack([render_frame(f, 320, 8) for f in half.frames if f.role == "code" and not f.inverse])
    word = codes.decode_bits(bits.astype(np.uint8), gray=True)
    np.testing.assert_array_equal(word[0], np.arange(320) // 10)
