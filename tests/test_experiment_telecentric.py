"""Quick variant of the telecentric experiment (ch. 3): diagonals, 50 um steps, plane flatness."""
import pytest

from fringe3d.experiments import telecentric as exp


@pytest.mark.slow
def test_quick_telecentric_measures_diagonals_steps_and_plane():
    r = exp.run(quick=True, seed=0)
    for f in r["figures"].values():
        assert f["diagonal_error_um"] < 20      # true diagonal 8*sqrt(2)*spacing
        assert f["step_error_um"] < 5           # 50 um stage steps
        assert f["plane_rms_um"] < 10
        assert f["camera_um"] < 10 and f["projector_um"] < 5
    seq, ref = r["figures"]["ch. 3 sequential"], r["figures"]["+ joint LM refinement"]
    assert ref["camera_px"] < seq["camera_px"]  # the joint refinement fits both devices better
    assert len(r["goals"]) == 10
