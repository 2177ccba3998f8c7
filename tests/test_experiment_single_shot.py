"""`fringe3d experiment single-shot --quick`: the figures it reports hold against the simulator's truth."""
import math

import pytest



@pytest.fixture(scope="module")
def result(quick_experiment):
    return quick_experiment("single-shot")


def test_single_shot_quick_meets_its_goals(result):
    assert result["goals"] and all(result["goals"].values()), result["goals"]


def test_single_shot_figures_are_consistent_with_the_goals(result):
    f = result["figures"]
    for key in ("ftp/circular", "ftp/hanning", "modified_ftp/circular", "modified_ftp/hanning"):
        assert f[key]["correct_order_share"] >= 0.999
        assert f[key]["pixels"] > 20000
        # single-shot vs PSP within a few mm, i.e. same absolute surface (one fringe is ~20 mm deep)
        assert 0 < f[key]["rms_vs_psp_mm"] < 2.0
    assert f["psp_rms_vs_truth_mm"] < 0.3
    lim = f["depth_limit"]
    assert lim["pixels_beyond_limit"] > 1000 and lim["beyond_off_by_minus_one"] >= 0.99
    assert lim["inside_wrong"] <= 1e-3 and lim["warned"]
    assert 20.0 < f["depth_range_mm"] < 60.0
    assert result["dissertation"]["FTP vs PSP+binary code (RMS)"] == "1.48 mm"
    assert {t["title"][:11] for t in result["tables"]} >= {"single-shot", "depth-range"}
    assert all(math.isfinite(r[4]) for r in result["tables"][0]["rows"])
