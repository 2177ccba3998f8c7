"""Report maps and plots against closed forms: robust colour limits, quality categories, camera-pixel
axes of a reduced preview, strain over time in seconds."""
from __future__ import annotations

import json
import re

import numpy as np

from fringe3d.decode.edges import EDGE, INVALID, RIM
from fringe3d.report.discover import MapItem
from fringe3d.report.map_view import map_figure, quality_categories, robust_limits
from fringe3d.report.strain_view import strain_series


def test_robust_limits_ignore_a_huge_background_and_centre_signed_maps():
    v = np.full((50, 50), np.nan)
    v[10:40, 10:40] = np.linspace(1.0, 2.0, 900).reshape(30, 30)
    v[0, 0] = 1e8  # one stray background value
    lo, hi = robust_limits(v, centred=False)
    finite = v[np.isfinite(v)]
    assert (lo, hi) == (np.percentile(finite, 1), np.percentile(finite, 99)) and hi < 3
    s = np.array([[-3.0, 1.0], [2.0, np.nan]])
    assert robust_limits(s, centred=True) == (-np.percentile([3, 1, 2], 99), np.percentile([3, 1, 2], 99))


def test_quality_categories_name_the_first_reason_bit():
    q = np.array([[0, INVALID | EDGE], [EDGE | RIM, RIM]], np.uint8)
    cat, labels = quality_categories(q)
    assert [labels[int(c)] for c in cat.ravel()] == ["ok", "invalid", "edge", "rim"]


def test_a_reduced_preview_keeps_full_resolution_camera_pixel_axes():
    m = MapItem("depth.tif", "depth", "mm", "Viridis", False, np.zeros((600, 1000), np.float32))
    cap, script = map_figure(m, "map_0")
    trace = json.loads(re.search(r"const t=(\{.*?\});", script).group(1))
    layout = json.loads(re.search(r"\],(\{.*?\}),\{responsive", script).group(1))
    assert trace["dx"] == trace["dy"] == 3  # every 3rd pixel: 334 x 200 samples
    assert layout["xaxis"]["range"] == [-0.5, 999.5] and layout["yaxis"]["range"] == [599.5, -0.5]
    assert "preview reduced 3×" in cap and "1000 × 600 camera px" in cap and "depth (mm)" in cap


def test_discrete_mask_has_one_colour_per_labelled_category():
    m = MapItem("mask_v.tif", "mask", "", "", False, np.array([[0, 1], [1, 1]], np.float32), "mask")
    _, script = map_figure(m, "map_0")
    trace = json.loads(re.search(r"const t=(\{.*?\});", script).group(1))
    assert trace["colorbar"]["ticktext"] == ["invalid", "valid"] and trace["colorbar"]["tickvals"] == [0, 1]
    assert len({c for _, c in trace["colorscale"]}) == 2


def test_strain_series_in_seconds_from_the_frame_rate(tmp_path):
    d = tmp_path / "arrays" / "wing_0"
    d.mkdir(parents=True)
    e = np.array([[0.0, 0.0, 9.0], [1e-4, 2e-4, 3e-4], [5e-4, 5e-4, 5e-4]])
    np.save(d / "dominant.npy", e)
    np.save(d / "ok.npy", np.array([[1, 1, 0], [1, 1, 1], [1, 1, 1]], bool))  # the 9.0 is untracked
    s = strain_series(tmp_path, 50.0)
    assert s["t"] == [0.0, 0.02, 0.04] and s["t_title"] == "time (s)"
    np.testing.assert_allclose(s["wings"]["wing_0"]["median"], [0.0, 200.0, 500.0])
    assert s["peak_frame"] == 2
    assert strain_series(tmp_path, None)["t_title"].startswith("frame")


def test_summary_rows_take_units_from_the_provenance_and_leave_it_out():
    from fringe3d.report.page import summary_rows

    summ = {"depth_min": 352.0, "files": {"depth": "depth.tif"}, "valid_share": 0.9,
            "provenance": {"command": "fringe3d reconstruct", "units": {"depth_min": "mm", "valid_share": "1"}}}
    assert summary_rows(summ) == [["depth_min", 352.0, "mm"], ["files.depth", "depth.tif", ""],
                                  ["valid_share", 0.9, "1"]]


def test_residual_plot_adds_the_map_over_the_image_only_when_points_match(tmp_path):
    from PIL import Image

    from fringe3d.calibrate.plots import residual_plot

    rng = np.random.default_rng(0)
    pts = [rng.uniform(0, 160, (20, 2)) for _ in range(3)]
    res = [rng.normal(0, 0.1, (20, 2)) for _ in range(3)]
    names = ["pose_00", "pose_01", "pose_02"]
    w3, h3 = Image.open(residual_plot(tmp_path / "a.png", res, res, names)).size
    w4, h4 = Image.open(residual_plot(tmp_path / "b.png", res, res, names, camera_points=pts,
                                      image_size=(160, 128))).size
    assert w3 > 2 * h3 and h4 > 0.7 * w4  # three panels in a row; 2 x 2 with the map
    wrong = residual_plot(tmp_path / "c.png", res, res, names, camera_points=pts[:2], image_size=(160, 128))
    assert Image.open(wrong).size == (w3, h3)  # points that do not match the residuals: no map
