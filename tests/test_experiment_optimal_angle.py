"""Quick variant of the optimal-angle experiment: alpha_opt from a step height (Eq. 2.5-2.7)
matches the rig's true epipolar direction, and both calibrations measure a sphere."""
import pytest



@pytest.mark.slow
def test_quick_optimal_angle_recovers_epipolar_direction_and_calibrates(quick_experiment):
    r = quick_experiment("optimal-angle")
    f = r["figures"]
    assert f["alpha_error_deg"] < 2.0 and r["goals"]["alpha_opt within 2 deg of truth"]
    assert 80 < f["alpha_true_deg"] < 100  # well-designed rig: nearly vertical fringes are optimal
    rows = r["tables"][1]["rows"]
    assert [row[0] for row in rows] == ["H/V", "alpha_opt -/+ pi/4"]
    for row in rows:
        assert row[2] < 0.1 and row[3] < 0.2     # reprojection RMS (px)
        assert 10 < row[4] < 200 and 10 < row[5] < 200  # section RMS (um): noise-limited, no gross error
