"""The report of a ``fringe3d merge`` folder: the fused model in a 3D view, the per-view table with
merge.json's values and units, coverage and the figures against the truth (``evaluate MERGED
--truth SIM``), read from the DOM of headless Chromium at 1400 and 800 px; the figures against the
truth pinned on a merge folder whose errors are known by construction."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from conftest import cli_ok
from headless_chromium import launch

from fringe3d.cli import main

SHOTS = Path("/tmp/report-shots")
WIDTHS = (1400, 800)

#: Layout facts and the tables of the multi-view section, computed in the browser.
FACTS_JS = """() => {
  const box = e => { const r = e.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; };
  const gd = document.getElementById('plot3d_merge');
  const fl = gd._fullLayout || {};
  const table = sel => { const t = document.querySelector(sel); if (!t) return null;
    return {head: Array.from(t.querySelectorAll('thead th')).map(e => e.textContent),
            rows: Array.from(t.querySelectorAll('tbody tr')).map(r => Array.from(r.cells).map(c => c.textContent)),
            box: box(t)}; };
  return {
    traces: (gd.data || []).map(d => ({type: d.type, n: (d.x || []).length, visible: d.visible,
                                       faces: (d.i || []).length})),
    scene: fl.scene ? ['xaxis', 'yaxis', 'zaxis'].map(k => (fl.scene[k].title || {}).text || '') : [],
    canvases: gd.querySelectorAll('canvas').length,
    modebar: Array.from(gd.querySelectorAll('.modebar')).map(box),
    buttons: Array.from(gd.querySelectorAll('.updatemenu-button')).map(e => ({text: e.textContent, box: box(e)})),
    plotBox: box(gd),
    titles: Array.from(document.querySelectorAll('h1,h2,h3')).map(e => ({text: e.textContent, box: box(e)})),
    views: table('table.views'), figures: table('table.merge'),
    provenance: (document.querySelector('table.provenance') || {}).textContent || '',
    scrollWidth: document.documentElement.scrollWidth, innerWidth: window.innerWidth};
}"""


@pytest.fixture(scope="module")
def merged(tmp_path_factory) -> dict:
    """Three views of the tiny sculpture on the virtual turntable, merged, evaluated against the
    truth and reported."""
    from fringe3d.sim import presets
    from fringe3d.sim.turntable import sculpture_turntable, turntable_views, write_turntable

    root = tmp_path_factory.mktemp("mvreport")
    p = presets.get("tiny")
    scan = turntable_views(sculpture_turntable(p, seed=0), p, [-20.0, 0.0, 20.0], sigma=0.05, seed=0)
    views = write_turntable(root / "scan", scan)
    out = root / "merged"
    cli_ok("merge", *map(str, views), "--poses", str(root / "scan" / "poses.json"), "-o", str(out), "--voxel", "4")
    cli_ok("evaluate", str(out), "--truth", str(root / "scan"))
    cli_ok("report", str(out))
    return {"folder": out, "page": out / "report.html",
            "merge": json.loads((out / "merge.json").read_text()),
            "evaluate": json.loads((out / "evaluate.json").read_text())}


@pytest.fixture(scope="module")
def facts(merged) -> dict:
    """``facts[width]``: the page's facts at each width (screenshots in /tmp/report-shots/), and
    ``facts["mesh"]``: the 3D view's traces after its mesh button is clicked."""
    from playwright.sync_api import sync_playwright

    SHOTS.mkdir(parents=True, exist_ok=True)
    out: dict = {}
    with sync_playwright() as p:
        browser = launch(p)
        page = browser.new_page(viewport={"width": WIDTHS[0], "height": 900})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.goto(merged["page"].resolve().as_uri())
        page.wait_for_selector("#plot3d_merge .main-svg", timeout=60_000)
        for width in WIDTHS:  # one load, resized: plotly's responsive layout follows the viewport
            page.set_viewport_size({"width": width, "height": 900})
            page.wait_for_timeout(300)
            page.screenshot(path=str(SHOTS / f"merge_{width}.png"), full_page=True)
            out[width] = page.evaluate(FACTS_JS)
        page.locator("#plot3d_merge .updatemenu-button", has_text="mesh").click()
        page.wait_for_timeout(300)
        out["mesh"] = page.evaluate(FACTS_JS)["traces"]
        out["errors"] = errors
        browser.close()
    return out


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _num(text: str) -> float:
    return float("nan") if text.strip() == "—" else float(text)


def _same(shown: str, value, scale: float = 1.0) -> bool:
    """The table's text (4 significant digits) shows ``value`` (None: —)."""
    if value is None:
        return shown.strip() == "—"
    return math.isclose(_num(shown), value * scale, rel_tol=1e-3, abs_tol=1e-12)


@pytest.mark.browser
def test_merge_report_draws_the_fused_model_and_its_mesh_without_script_errors(facts, merged):
    f = facts[1400]
    assert facts["errors"] == []
    kinds = {t["type"]: t for t in f["traces"]}
    assert kinds["scatter3d"]["n"] == merged["merge"]["fused_points"]  # fewer than the cap: every point
    assert kinds["mesh3d"]["faces"] == merged["merge"]["mesh"]["triangles"]
    assert f["scene"] == ["x (mm)", "y (mm)", "z (mm)"]
    assert f["canvases"] > 0  # WebGL drew the scene
    assert [b["text"] for b in f["buttons"]] == ["points: views", "points: σ (mm)", "mesh"]
    after = {t["type"]: t["visible"] for t in facts["mesh"]}
    assert after == {"scatter3d": False, "mesh3d": True}
    assert "fringe3d merge" in f["provenance"] and merged["merge"]["views"][0]["name"] in f["provenance"]


@pytest.mark.browser
def test_merge_report_lists_every_view_with_merge_json_values_units_and_truth(facts, merged):
    t = facts[1400]["views"]
    assert t["head"][:6] == ["view", "residual RMS (mm)", "pose 1σ rotation (mrad)", "pose 1σ translation (µm)",
                             "points", "overlap (%)"]
    assert t["head"][6:] == ["rotation error vs truth (mrad)", "translation error vs truth (µm)"]
    views, truth = merged["merge"]["views"], merged["evaluate"]["multiview"]["views"]
    assert [r[0] for r in t["rows"]] == [v["name"] for v in views]
    for row, v, tv in zip(t["rows"], views, truth):
        assert _same(row[1], v["residual_rms_mm"]) and _same(row[2], v["rotation_sigma_mrad"])
        assert _same(row[3], v["translation_sigma_um"]) and int(row[4]) == v["points"]
        assert _same(row[5], v["overlap_share"], 100.0)
        assert _same(row[6], tv["rotation_error_mrad"]) and _same(row[7], tv["translation_error_um"])
    figs = {r[0]: r for r in facts[1400]["figures"]["rows"]}
    assert _same(figs["seen by ≥ 2 views"][1], merged["merge"]["fused_overlap_share"], 100.0)
    assert figs["seen by ≥ 2 views"][2] == "%"
    mv = merged["evaluate"]["multiview"]
    assert _same(figs["fused RMS vs truth"][1], mv["fused_rms_mm"]) and figs["fused RMS vs truth"][2] == "mm"
    assert _same(figs["coverage of the true surface"][1], mv["coverage"], 100.0)
    assert mv["coverage"] >= 0.98 and mv["fused_rms_mm"] < 0.1  # mm: 0.05 mm noise, three views


@pytest.mark.browser
@pytest.mark.parametrize("width", WIDTHS)
def test_merge_report_fits_the_width_with_toolbar_and_buttons_clear_of_titles(facts, width):
    f = facts[width]
    assert f["scrollWidth"] <= f["innerWidth"]  # nothing overflows sideways
    for sel in ("views", "figures"):
        assert f[sel]["box"][2] <= f["innerWidth"]
    boxes = [mb for mb in f["modebar"] if mb[2] > mb[0]]
    assert boxes, "the 3D view has its toolbar in the DOM"
    for b in f["buttons"]:
        assert f["plotBox"][0] <= b["box"][0] and b["box"][2] <= f["plotBox"][2]
        for mb in boxes:
            assert not _overlap(b["box"], mb), f"plotly toolbar covers the button {b['text']!r}"
    for t in f["titles"]:
        for mb in boxes:
            assert not _overlap(t["box"], mb), f"plotly toolbar covers the title {t['text']!r}"


def test_merge_truth_figures_recover_a_known_pose_error_and_surface_offset(tmp_path, capsys):
    """A merge folder built by hand: view 1's pose off its true pose by 2 mrad about an axis through
    the object's centre (so the error moves the centre by 0), the fused cloud the true surface moved
    0.1 mm along its normals (RMS 0.1 mm), covering all of it."""
    from fringe3d.devices.stage import rotation_about
    from fringe3d.io.ply_standard import write_standard_ply
    from fringe3d.multiview.poses import write_poses

    rng = np.random.default_rng(0)
    g = np.stack(np.meshgrid(np.linspace(-40, 40, 81), np.linspace(-30, 30, 61)), -1).reshape(-1, 2)
    z = 400.0 + 5.0 * np.sin(g[:, 0] / 15.0)
    truth = np.column_stack([g, z])
    n = np.column_stack([-np.cos(g[:, 0] / 15.0) / 3.0, np.zeros(len(g)), np.ones(len(g))])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    true = np.stack([np.eye(4), rotation_about([0.0, 1.0, 0.0], np.deg2rad(20.0), truth.mean(0))])
    sim = tmp_path / "sim"
    sim.mkdir()
    np.savez(sim / "truth.npz", points=truth, normals=n, poses=true)
    est = true.copy()
    est[1] = true[1] @ rotation_about(rng.normal(size=3), 2e-3, truth.mean(0))
    out = tmp_path / "merged"
    out.mkdir()
    names = ["view-00", "view-01"]
    write_poses(out / "poses.json", names, est)
    write_standard_ply(out / "fused.ply", truth + 0.1 * n, normals=False)
    (out / "merge.json").write_text(json.dumps({"views": [{"name": k} for k in names]}))
    assert main(["evaluate", str(out), "--truth", str(sim), "--json"]) == 0
    mv = json.loads(capsys.readouterr().out)["multiview"]
    assert [v["rotation_error_mrad"] for v in mv["views"]] == pytest.approx([0.0, 2.0], abs=1e-6)
    assert [v["translation_error_um"] for v in mv["views"]] == pytest.approx([0.0, 0.0], abs=1e-3)
    assert mv["fused_rms_mm"] == pytest.approx(0.1, rel=1e-3)
    assert mv["coverage"] == 1.0
    assert json.loads((out / "evaluate.json").read_text())["multiview"] == mv


def test_report_mesh_is_cut_to_the_limit_by_vertex_clustering_staying_on_the_surface():
    import trimesh
    from fringe3d.report.multiview_view import cluster_mesh
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=50.0)  # 5120 triangles
    V, F = cluster_mesh(sphere.vertices, sphere.faces, 1000)
    assert 250 < len(F) <= 1000 and F.max() < len(V)
    assert np.abs(np.linalg.norm(V, axis=1) - 50.0).max() < 5.0  # mm: a cell's mean stays near the sphere
    same = cluster_mesh(sphere.vertices, sphere.faces, 10_000)
    assert len(same[1]) == 5120


def test_report_refuses_a_merge_json_without_views_naming_the_file_and_field(tmp_path):
    from fringe3d.report import write_report
    (tmp_path / "merge.json").write_text(json.dumps({"views": 3}))
    with pytest.raises(ValueError, match=r"merge\.json: field 'views' must be a list"):
        write_report(tmp_path)
    assert not (tmp_path / "report.html").exists()
