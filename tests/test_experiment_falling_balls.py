"""`fringe3d experiment falling-balls --quick`: hybrid FTP+PSP vs two-frequency PSP on falling balls."""
import pytest



@pytest.fixture(scope="module")
def result(quick_experiment):
    return quick_experiment("falling-balls")


def test_falling_balls_quick_meets_its_goals(result):
    assert result["goals"] and all(result["goals"].values()), result["goals"]


def test_falling_balls_figures_back_the_goals(result):
    two = result["figures"]["two balls, realistic noise"]
    assert len(two) == 2
    for b in two:
        assert b["k_error"] == 0
        assert b["hybrid_rms"] <= 0.26
        assert b["psp_rms"] >= 27 * b["hybrid_rms"]
        assert 19.0 < b["hybrid_radius"] < 23.0  # a 40 mm ball, slightly flattened by FTP's low-pass
        assert b["hybrid_points"] > 2000 and b["psp_points"] > 2000
    many = result["figures"]["20 balls, realistic noise"]
    assert len(many) >= 20 and all(b.get("k_error") == 0 for b in many)
    assert result["dissertation"]["hybrid sphere RMS"] == "0.26 mm"


def test_thrown_balls_need_the_cross_motion_correction(result):
    thrown = result["figures"]["thrown"]
    assert thrown, "the quick run measures at least one sideways speed"
    for r in thrown.values():
        assert r["cross_motion"] == [0, 0]
        assert any(e != 0 for e in r["eq_5_13"])  # Eq. (5.13) as printed slips a fringe at 3 m/s sideways


def test_every_ball_fully_in_view_keeps_its_order_over_consecutive_cycles(result):
    seq = result["figures"]["sequence"]
    assert seq["cycles"] >= 2 and seq["ball_cycles"] >= 20 * seq["cycles"] - 10
    assert seq["right"] == seq["ball_cycles"] and seq["lost"] == 0
