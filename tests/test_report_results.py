"""`fringe3d report` on plain command outputs (no summary.json): a simulate -> reconstruct ->
evaluate folder, a decode folder and a calibration JSON; the page renders in headless Chromium."""
from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from headless_chromium import launch

from fringe3d.cli import main
from fringe3d.report.typed import b64_float32, b64_uint16, decode_float32, decode_uint16



@pytest.fixture(scope="module")
def evaluated(tmp_path_factory) -> Path:
    """A tiny simulated sphere, reconstructed and evaluated against its truth."""
    root = tmp_path_factory.mktemp("report")
    cap, rec = root / "cap", root / "rec"
    assert main(["simulate", "-o", str(cap), "--scene", "sphere", "--ideal", "-q"]) == 0
    assert main(["reconstruct", str(cap), "-c", str(cap / "rig.json"), "-o", str(rec), "-q"]) == 0
    assert main(["evaluate", str(rec), "--sphere", "--truth", str(cap), "-q"]) == 0
    return rec


def test_typed_arrays_round_trip_with_nan():
    a = np.array([1.5, np.nan, -2.25e3], np.float32)
    np.testing.assert_array_equal(decode_float32(b64_float32(a)), a)


def test_quantised_coordinates_round_trip_within_half_a_step():
    x = np.random.default_rng(0).uniform(-120.0, 80.0, 5000)
    text, lo, step = b64_uint16(x)
    assert step == pytest.approx(200.0 / 65535, rel=1e-3)
    assert np.abs(decode_uint16(text, lo, step) - x).max() <= step / 2 + 1e-12
    flat, lo1, step1 = b64_uint16(np.full(4, 7.0))  # a constant coordinate: step 0
    np.testing.assert_array_equal(decode_uint16(flat, lo1, step1), np.full(4, 7.0))


def test_report_of_a_reconstruct_and_evaluate_folder(evaluated: Path):
    assert main(["report", str(evaluated), "-q"]) == 0
    page = (evaluated / "report.html").read_text()
    marker = json.loads((evaluated / "fringe3d.json").read_text())
    assert marker["command"] in page and marker["fringe3d"] in page  # provenance
    assert "baseline |C_p - C_c| (mm)" not in page  # the calibration lies outside: not read
    assert "probing error form P_F" in page and "probing error size P_S" in page
    assert "VDI/VDE 2634-2" in page
    for name in ("truth_error.tif", "sphere_residuals.tif", "depth.tif"):
        assert f'title="{name}"' in page  # maps with colour bars
    # point data travel as base64 typed arrays, not JSON numbers; plotly.js gzip-compressed
    assert re.search(r'"x": "[A-Za-z0-9+/=]{1000,}"', page)
    assert (evaluated / "report.html").stat().st_size < 3_500_000
    assert main(["report", str(evaluated), "-q"]) == 2  # an existing report needs --overwrite
    calibration = json.loads((evaluated / "reconstruct.json").read_text())["calibration"]
    shutil.copy(calibration, evaluated / Path(calibration).name)  # a copy inside the folder is shown
    assert main(["report", str(evaluated), "-q", "--overwrite"]) == 0
    assert "baseline |C_p - C_c| (mm)" in (evaluated / "report.html").read_text()


def test_report_of_a_calibration_json(evaluated: Path, tmp_path: Path):
    rig = json.loads((evaluated.parent / "cap" / "rig.json").read_text())
    cal = {"format": "fringe3d-calibration", "version": 1, "model": "pinhole", "rig": rig,
           "poses": [{"name": "pose_00", "camera_rms_px": 0.05, "projector_rms_px": 0.08, "points": 81}],
           "rms": {"camera_px": 0.05, "projector_px": 0.08}}
    (tmp_path / "calib.json").write_text(json.dumps(cal))
    assert main(["report", str(tmp_path / "calib.json"), "-q"]) == 0
    page = (tmp_path / "calib.html").read_text()
    assert "Per-pose residuals" in page and "pose_00" in page and "fx (px)" in page


@pytest.mark.browser
def test_reconstruct_evaluate_report_renders_at_two_widths(evaluated: Path):
    from playwright.sync_api import sync_playwright

    out = evaluated.parent / "browser.html"
    assert main(["report", str(evaluated), "-o", str(out), "-q"]) == 0
    errors: list[str] = []
    with sync_playwright() as p:
        browser = launch(p)
        for width in (1400, 800):
            page = browser.new_page(viewport={"width": width, "height": 900})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(out.resolve().as_uri())
            page.wait_for_selector("#plot3d_0 .main-svg", timeout=30_000)
            page.wait_for_selector("#map_0 .main-svg", timeout=30_000)
            n_maps = page.locator(".map .colorbar").count()
            has_gl = page.locator("#plot3d_0 canvas").count() + page.locator("#plot3d_0 .gl-container").count()
            n_figures = page.locator("table.figures tbody tr").count()
            shot = evaluated.parent / f"report_{width}.png"
            page.screenshot(path=str(shot), full_page=True)
            assert n_maps >= 3 and has_gl > 0 and n_figures >= 5
            assert shot.stat().st_size > 20_000
        browser.close()
    assert errors == []


def test_report_of_a_decode_folder(evaluated: Path):
    dec = evaluated.parent / "dec"
    assert main(["decode", str(evaluated.parent / "cap"), "-o", str(dec), "-q"]) == 0
    assert main(["report", str(dec), "-q"]) == 0
    page = (dec / "report.html").read_text()
    for name in ("phase_v.tif", "modulation_v.tif", "mask_v.tif"):
        assert f'title="{name}"' in page
    assert "decoded.json" in page and "fringe3d decode" in page
