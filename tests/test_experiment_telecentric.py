"""Quick variant of the telecentric experiment (ch. 3): diagonals, 50 um steps, plane flatness."""
import pytest

from fringe3d.experiments import telecentric as exp


@pytest.mark.slow
def test_quick_telecentric_measures_diagonals_steps_and_plane():
    r = exp.run(quick=True, seed=0)
    f = r["figures"]
    assert f["diagonal_error_um"] < 20      # true diagonal 8*sqrt(2)*spacing
    assert f["step_error_um"] < 5           # 50 um stage steps
    assert f["plane_rms_um"] < 10
    assert f["camera_rms_um"] < 10 and f["projector_rms_um"] < 5
    assert set(r["goals"]) == {"camera reprojection <= 1.8 um", "projector reprojection <= 1.2 um",
                               "board diagonal error <= 9 um", "50 um step error <= 1.7 um", "plane RMS <= 4.5 um"}
