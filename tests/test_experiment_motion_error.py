"""Experiment motion-error (ch. 5.2.4): a sphere moving 2% of its diameter per frame."""
from fringe3d.experiments import get


def test_moving_sphere_error_is_periodic_and_many_times_the_static_error(quick_experiment):
    res = quick_experiment("motion-error")
    fig = res["figures"]
    static, moving = res["tables"][0]["rows"]
    assert static[0] == "static sphere" and moving[0].startswith("moving")
    # static: only quantisation / pixelation remain (phase RMS well under 0.01 rad)
    assert fig["static_phase_rms_rad"] < 0.01
    # moving: many times the static 3D error, mostly oscillating with the fringes
    assert fig["moving_rms_mm"] >= 5 * fig["static_rms_mm"]
    assert fig["periodic_fraction"] >= 0.5
    assert moving[7] == 0  # no fringe-order errors: the error is the motion-induced ripple
    assert all(res["goals"].values())
    assert "2%" in res["dissertation"]["motion"]


def test_motion_error_is_repeatable_for_a_seed():
    a = get("motion-error").run(quick=True, seed=1)["figures"]
    b = get("motion-error").run(quick=True, seed=1)["figures"]
    assert a == b
