"""Report pages as a reviewer sees them: headless Chromium at 1400 and 800 px on the demo, decode,
reconstruct + evaluate, strain and calibration reports of tiny simulated runs. Each test asserts
layout facts read from the DOM and plotly's layout (bounding boxes, axis ranges, unit strings),
not pixel hashes; the screenshots go to /tmp/report-shots/ for a person to look at."""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest
from conftest import cli_ok, write_wing_sequence

from headless_chromium import launch

from fringe3d.cli import main
from fringe3d.io.images import read_image

SHOTS = Path("/tmp/report-shots")
WIDTHS = (1400, 800)

pytestmark = pytest.mark.browser

#: Layout facts of the page, computed in the browser.
FACTS_JS = """() => {
  const box = e => { const r = e.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; };
  const plots = Array.from(document.querySelectorAll('.js-plotly-plot')).map(gd => {
    const fl = gd._fullLayout || {}, d = (gd.data || [])[0] || {};
    const axis = a => a ? {range: a.range, title: (a.title || {}).text || ''} : null;
    const scene = fl.scene ? ['xaxis', 'yaxis', 'zaxis'].map(k => (fl.scene[k].title || {}).text || '') : [];
    return {id: gd.id, x: axis(fl.xaxis), y: axis(fl.yaxis), scene: scene, type: d.type,
            zmin: d.zmin, zmax: d.zmax, ticktext: (d.colorbar || {}).ticktext || null,
            colorscale: d.colorscale, cbtitle: ((d.colorbar || {}).title || {}).text || '',
            modebar: Array.from(gd.querySelectorAll('.modebar')).map(box)};
  });
  const titles = Array.from(document.querySelectorAll('h1,h2,h3,figcaption,.gtitle')).map(e => ({
    text: e.textContent, box: box(e)}));
  const b = document.body.getBoundingClientRect();
  return {plots, titles, scrollWidth: document.documentElement.scrollWidth, innerWidth: window.innerWidth,
          bodyLeft: b.left, bodyRight: window.innerWidth - b.right,
          fontPx: parseFloat(getComputedStyle(document.body).fontSize),
          h1: (document.querySelector('h1') || {}).textContent || '',
          images: Array.from(document.querySelectorAll('img.fig')).map(e => e.alt),
          provenance: (document.querySelector('table.provenance') || {}).textContent || '',
          accuracyHeader: (document.querySelector('table.accuracy thead') || {}).textContent || null};
}"""


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict:
    """One tiny simulated run of each command, shared by every test here."""
    root = tmp_path_factory.mktemp("layout")
    cap, rec, dec, demo = root / "cap", root / "rec", root / "dec", root / "demo"
    cli_ok("simulate", "-o", str(cap), "--scene", "sphere", "--ideal")
    cli_ok("reconstruct", str(cap), "-c", str(cap / "rig.json"), "-o", str(rec))
    cli_ok("evaluate", str(rec), "--sphere", "--truth", str(cap))
    cli_ok("decode", str(cap), "-o", str(dec))
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["demo", "--profile", "tiny", "-o", str(demo), "--json"]) == 0
    seq = root / "seq"
    seq.mkdir()
    anchors, _ = write_wing_sequence(seq, (0.0, 0.01, 0.02))
    cli_ok("strain", str(seq), "--anchors", ",".join(f"{x:.3f}" for x in anchors.ravel()), "-o", str(root / "strain"),
         "--thickness", "0.1", "--step", "6", "--window", "9", "--frame-rate", "100")
    pages = {"demo": demo / "report.html"}
    for name, folder in (("decode", dec), ("evaluate", rec), ("strain", root / "strain")):
        cli_ok("report", str(folder))
        pages[name] = folder / "report.html"
    cli_ok("report", str(demo / "calibration.json"))
    pages["calibration"] = demo / "calibration.html"
    return {"pages": pages, "dec": dec, "rec": rec}


@pytest.fixture(scope="module")
def facts(runs) -> dict:
    """``facts[(report, width)]``: the layout facts of each page at each width (screenshots saved)."""
    from playwright.sync_api import sync_playwright

    SHOTS.mkdir(parents=True, exist_ok=True)
    out: dict = {}
    with sync_playwright() as p:
        browser = launch(p)
        for name, path in runs["pages"].items():
            for width in WIDTHS:
                page = browser.new_page(viewport={"width": width, "height": 900})
                errors: list[str] = []
                page.on("pageerror", lambda e, errors=errors: errors.append(str(e)))
                page.goto(path.resolve().as_uri())
                page.wait_for_function("() => document.querySelectorAll('.js-plotly-plot').length > 0 || "
                                       "!document.querySelector('[id^=map_],[id^=plot3d_],[id^=strain_]')",
                                       timeout=60_000)
                page.wait_for_timeout(300)
                page.screenshot(path=str(SHOTS / f"{name}_{width}.png"), full_page=True)
                out[name, width] = {**page.evaluate(FACTS_JS), "errors": errors}
                page.close()
        browser.close()
    return out


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("report", ["demo", "decode", "evaluate", "strain", "calibration"])
def test_page_fits_the_width_without_toolbar_over_titles_or_script_errors(facts, report, width):
    f = facts[report, width]
    assert f["errors"] == []
    assert f["scrollWidth"] <= f["innerWidth"]  # no horizontal overflow
    assert abs(f["bodyLeft"] - f["bodyRight"]) <= 2  # content centred, not flush left
    assert f["fontPx"] >= 14
    boxes = [mb for pl in f["plots"] for mb in pl["modebar"] if mb[2] > mb[0]]
    assert len(boxes) == len(f["plots"])  # every plot has its toolbar in the DOM: the check below is real
    for t in f["titles"]:
        for mb in boxes:
            assert not _overlap(t["box"], mb), f"plotly toolbar covers the title {t['text']!r}"


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("report, folder", [("decode", "dec"), ("evaluate", "rec")])
def test_maps_span_the_camera_in_pixels_with_units(facts, runs, report, folder, width):
    maps = [p for p in facts[report, width]["plots"] if p["id"].startswith("map_")]
    assert len(maps) >= 3
    h, w = read_image(next(runs[folder].glob("*.tif"))).shape[:2]
    for m in maps:
        assert m["x"]["range"] == pytest.approx([-0.5, w - 0.5]) and m["y"]["range"] == pytest.approx([h - 0.5, -0.5])
        assert m["x"]["title"] == "u (camera px)" and m["y"]["title"] == "v (camera px)"
        assert m["ticktext"] or m["cbtitle"]  # a unit on every continuous colour bar


def test_decode_masks_and_quality_are_discrete_and_phase_sigma_has_robust_limits(facts, runs):
    plots = {p["id"]: p for p in facts["decode", 1400]["plots"]}
    titles = [t["text"] for t in facts["decode", 1400]["titles"]]
    kinds = {"mask": ["valid"], "quality": ["ok"]}
    for kind, must in kinds.items():
        i = next(k for k, t in enumerate(t for t in titles if "camera px" in t) if f"{kind}_" in t)
        p = plots[f"map_{i}"]
        assert p["ticktext"] and all(x in p["ticktext"] for x in must), kind
        assert len({c for _, c in p["colorscale"]}) == len(p["ticktext"])  # one flat colour per category
    i = next(k for k, t in enumerate(t for t in titles if "camera px" in t) if "phase_sigma_" in t)
    sigma = read_image(next(runs["dec"].glob("phase_sigma_*.tif")))
    mask = read_image(next(runs["dec"].glob("mask_*.tif"))) > 0
    assert "σ_φ" in titles[[k for k, t in enumerate(titles) if "camera px" in t][i]]
    assert plots[f"map_{i}"]["zmax"] <= np.nanpercentile(sigma[mask], 99.5)


def test_reconstruct_report_shows_quality_and_sigma_z_and_a_signed_error_map(facts):
    titles = " ".join(t["text"] for t in facts["evaluate", 1400]["titles"])
    assert "quality.tif" in titles and "sigma_z.tif" in titles and "truth_error.tif" in titles
    err = next(p for p in facts["evaluate", 1400]["plots"] if p["id"].startswith("map_") and p["zmin"] is not None
               and p["zmin"] < 0 and p["cbtitle"] == "mm")
    assert err["zmin"] == pytest.approx(-err["zmax"])  # diverging, centred on 0
    scene = next(p for p in facts["evaluate", 1400]["plots"] if p["scene"])
    assert scene["scene"] == ["x (mm)", "y (mm)", "z (mm)"]


def test_strain_report_plots_strain_over_time_in_seconds(facts):
    plots = {p["id"]: p for p in facts["strain", 1400]["plots"]}
    assert plots["strain_0"]["x"]["title"] == "time (s)" and "µε" in plots["strain_0"]["y"]["title"]
    assert plots["strain_0"]["x"]["range"][1] >= 0.02 - 1e-9  # 3 frames at 100 Hz
    assert sum("strain_0" in t["text"] for t in facts["strain", 1400]["titles"]) <= 1  # one map, not a stack


def test_calibration_and_demo_reports_carry_a_title_and_provenance(facts, runs):
    cal = facts["calibration", 1400]
    assert "calibration.json" in cal["h1"]
    assert cal["images"] == ["calibration_residuals.png"]  # the residual plot beside the calibration
    from PIL import Image

    w, h = Image.open(runs["pages"]["demo"].parent / "calibration_residuals.png").size
    assert h > 0.7 * w  # 2 x 2: the fourth panel is the residual map over the image
    marker = json.loads((runs["pages"]["demo"].parent / "fringe3d.json").read_text())
    assert "fringe3d version" in cal["provenance"] and "no fringe3d.json" not in cal["provenance"]
    demo = facts["demo", 1400]
    assert marker["fringe3d"] in demo["provenance"]
    assert demo["accuracyHeader"] is not None and "truth" not in demo["accuracyHeader"]


def test_truth_error_map_is_signed(runs):
    err = read_image(runs["rec"] / "truth_error.tif")
    assert np.nanmin(err) < 0 < np.nanmax(err)  # noise on both sides of the truth: |error| would be >= 0
