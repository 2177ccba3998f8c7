"""The HTML report renders in a real headless browser with no console errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from headless_chromium import launch

from fringe3d.report import write_report
from fringe3d.report.results import save_summary



def _sphere_points(h=60, w=80, r=20.0, z0=300.0):
    v, u = np.mgrid[0:h, 0:w]
    x = (u - w / 2) * 0.6
    y = (v - h / 2) * 0.6
    rr = x**2 + y**2
    z = np.where(rr < r * r, z0 - np.sqrt(np.clip(r * r - rr, 0, None)), np.nan)
    pts = np.stack([x, y, z], axis=-1).astype(np.float32)
    pts[~np.isfinite(z)] = np.nan
    return pts


@pytest.fixture
def results_folder(tmp_path: Path) -> Path:
    np.save(tmp_path / "points_sphere.npy", _sphere_points())
    save_summary(tmp_path, {
        "title": "test report",
        "calibration": {"figures": {"camera reprojection RMS (px)": 0.012}, "poses": [{"pose": 0, "rms_px": 0.01}]},
        "measurements": [{"name": "sphere", "points": "points_sphere.npy", "metrics": {"sphere RMS (mm)": 0.05}}],
        "accuracy": [{"quantity": "sphere RMS", "value": 0.05, "unit": "mm", "dissertation": "0.071"}],
        "stages": [{"name": "render", "seconds": 1.0}],
    })
    return tmp_path


def test_report_is_self_contained(results_folder: Path):
    html = write_report(results_folder).read_text()
    assert "http://" not in html.split("<body>", 1)[1].replace("http://www.w3.org", "")
    assert "<script src=" not in html  # no external scripts
    assert "Plotly.newPlot" in html


@pytest.mark.browser
def test_report_renders_3d_view_and_tables_without_console_errors(results_folder: Path):
    from playwright.sync_api import sync_playwright


    path = write_report(results_folder)
    errors: list[str] = []
    with sync_playwright() as p:
        browser = launch(p)
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(path.resolve().as_uri())
        page.wait_for_selector("#plot3d_0 .main-svg", timeout=30_000)
        n_rows = page.locator("table.accuracy tbody tr").count()
        has_gl = page.locator("#plot3d_0 canvas").count() + page.locator("#plot3d_0 .gl-container").count()
        page.screenshot(path=str(results_folder / "report.png"), full_page=True)
        browser.close()
    assert errors == []
    assert n_rows == 1
    assert has_gl > 0
    assert (results_folder / "report.png").stat().st_size > 10_000


def test_report_shows_sequence_goals_and_tables(results_folder: Path):
    from fringe3d.report.results import load_summary
    s = load_summary(results_folder)
    s["sequences"] = {"falling-balls": {"goals": {"hybrid RMS <= 0.26 mm": True},
                                        "tables": [{"title": "per ball", "columns": ["ball", "RMS (mm)"],
                                                    "rows": [[0, 0.22]]}], "seconds": 1.0}}
    save_summary(results_folder, s)
    html = write_report(results_folder).read_text()
    assert "Sequence: falling-balls" in html and "hybrid RMS &lt;= 0.26 mm" in html and "per ball" in html
