"""Quick variant of the telecentric experiment (ch. 3): diagonals, 50 um steps, plane flatness."""
import pytest



@pytest.mark.slow
def test_quick_telecentric_measures_diagonals_steps_and_plane(quick_experiment):
    r = quick_experiment("telecentric")
    seq, ref = r["figures"]["sequential, bilinear"], r["figures"]["joint LM, bilinear"]
    loc = r["figures"]["sequential, local fit"]
    # quick variant: 320x256 camera, 5 poses, preset noise; true diagonal 8*sqrt(2)*spacing
    assert ref["diagonal_error_um"] < 10 and seq["diagonal_error_um"] < 60
    assert ref["step_error_um"] < 5 and seq["step_error_um"] < 5   # 50 um stage steps
    assert ref["plane_rms_um"] < 10 and seq["plane_rms_um"] < 10
    assert ref["camera_um"] < 5 and seq["camera_um"] < 40
    assert ref["projector_um"] < 5 and seq["projector_um"] < 5
    assert ref["camera_px"] < seq["camera_px"]  # the joint refinement fits both devices better
    # the local phase fit averages noise over the circle (few pixels at 320x256: 30 % less, 3.7x at full size)
    assert loc["projector_px"] < 0.8 * seq["projector_px"] and loc["camera_px"] < seq["camera_px"]
    assert len(r["goals"]) == 20
