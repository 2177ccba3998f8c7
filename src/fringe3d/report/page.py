"""The report page of any results folder, built from what :func:`.discover.discover` found:
provenance, calibration, measurement figures with their definitions, maps with colour bars and
a 3D view of the points. Point and map data travel as base64 float32 (:mod:`.typed`)."""
from __future__ import annotations

import base64
import html
import json

import numpy as np

from .calibration_view import calibration_tables
from .definitions import DEFINITIONS, SECTION_TITLES
from .discover import FolderContents
from .plotly_bundle import draw_script, loader_script
from .map_view import map_figure
from .multiview_view import multiview_parts
from .radiometry_view import radiometry_parts
from .strain_view import strain_script
from .typed import JS_DECODE, b64_uint16, sample_points

MAX_POINTS_3D = 60_000

PAGE_CSS = """
.maps{display:grid;grid-template-columns:repeat(auto-fit,minmax(340px,1fr));gap:12px}
.strainplot{height:380px} figure.map{margin:0;border:1px solid #eee;min-width:0} .mapplot{height:360px}
.maptitle{font-weight:600;font-size:.95em;padding:.3em .5em} .maptitle .muted{font-weight:400}
.warn{background:#fff4d6;border-left:4px solid #e0a800;padding:.4em .8em}
table.provenance td,table.provenance th,table.summary td,table.summary th{text-align:left} .scroll{overflow-x:auto}
table.figures td:last-child{text-align:left;color:#555;max-width:520px} table.figures th:last-child{text-align:left}
table.views td:first-child{white-space:nowrap}
@media (max-width:900px){body{margin:1em auto} .plot3d{height:420px}}
"""


def _scalar_rows(d: dict, prefix: str = "") -> list[list]:
    rows = []
    for k, v in d.items():
        if isinstance(v, dict):
            rows += _scalar_rows(v, f"{prefix}{k}.")
        elif not isinstance(v, list):
            rows.append([f"{prefix}{k}", v])
    return rows


def summary_rows(summ: dict) -> list[list]:
    """``[field, value, unit]`` rows of a command's summary JSON; its ``provenance`` (shown in the
    provenance section) gives the units and is left out of the rows."""
    units = ((summ.get("provenance") or {}).get("units") or {}) if isinstance(summ.get("provenance"), dict) else {}
    body = {k: v for k, v in summ.items() if k != "provenance"}
    return [[k, v, units.get(k, units.get(k.split(".")[-1], ""))] for k, v in _scalar_rows(body)]


def file_provenance_rows(prov: dict, source: str) -> list[list]:
    """Rows of the ``"provenance"`` object a fringe3d JSON file carries (version, time, command)."""
    rows = [["from", f"{source} (its provenance)"], ["fringe3d version", prov.get("fringe3d_version")],
            ["written", prov.get("written")], ["command", prov.get("command")]]
    return [r for r in rows if r[1] is not None]


def provenance_rows(marker: dict | None, fallback: tuple[dict, str] | None = None) -> list[list]:
    """Rows of ``fringe3d.json``: version, command, times, inputs, fingerprint, completeness; without
    one, the ``fallback`` ``(provenance, file name)`` of a JSON file (a calibration)."""
    if not marker and fallback and isinstance(fallback[0], dict):
        return file_provenance_rows(*fallback)
    if not marker:
        return [["provenance", "no fringe3d.json (a folder not written by fringe3d)"]]
    rows = [["fringe3d version", marker.get("fringe3d")], ["command", marker.get("command")],
            ["started", marker.get("started")], ["finished", marker.get("finished")],
            ["complete", marker.get("complete")], ["inputs", ", ".join(map(str, marker.get("inputs") or []))],
            ["input fingerprint", marker.get("fingerprint")], ["files", len(marker.get("files") or [])]]
    return [r for r in rows if r[1] not in (None, "")]


def evaluation_parts(ev: dict, table) -> list[str]:
    """One table per evaluated section, each figure with its unit and definition (nothing when
    ``ev`` holds none of :data:`~.definitions.SECTION_TITLES`' sections)."""
    if not any(isinstance(ev.get(sect), dict) for sect in SECTION_TITLES):
        return []
    parts = ["<h2>Measurement figures</h2>"]
    for sect, title in SECTION_TITLES.items():
        figs = ev.get(sect)
        if not isinstance(figs, dict):
            continue
        defs = DEFINITIONS.get(sect, {})
        rows = [[defs[k][0], figs[k], defs[k][1], defs[k][2]] for k in defs if k in figs]
        if sect == "ball_bar":
            for i, sp in enumerate(figs.get("spheres", [])):
                rows += [[f"sphere {i} {DEFINITIONS['sphere'][k][0]}", sp[k], "mm", DEFINITIONS["sphere"][k][2]]
                         for k in ("form", "size", "rms") if sp.get(k) is not None]
        rule = figs.get("outliers")
        rules = rule if isinstance(rule, list) else [rule] if rule else []
        for r in rules:
            rows.append(["outliers excluded", f"{r.get('excluded_points')} ({100 * r.get('excluded_share', 0):.3g} %)",
                         "", r.get("rule", "")])
        parts.append(f"<h3>{html.escape(title)}</h3>")
        parts += [f'<p class="warn">{html.escape(w)}</p>' for w in figs.get("warnings", [])]
        parts.append('<div class="scroll">' + table(rows, ["figure", "value", "unit", "definition"],
                                                     f"figures {sect}") + "</div>")
    return parts


def points_script(points: np.ndarray, div: str) -> str:
    """JavaScript drawing at most :data:`MAX_POINTS_3D` of ``points`` as a plotly scatter3d
    (coordinates as base64 uint16 over their range, :func:`~.typed.b64_uint16`, coloured by z),
    seen from the camera's side (its caption is the caller's HTML, never a plotly title the toolbar
    would cover)."""
    p = sample_points(points, MAX_POINTS_3D)
    data: dict = {}
    for i, ax in enumerate("xyz"):
        data[ax], data[ax + "0"], data["d" + ax] = b64_uint16(p[:, i])
    span = np.ptp(p, axis=0) if len(p) else np.ones(3)
    ratio = np.maximum(span / max(float(span.max()), 1e-12), 0.25)  # a flat plane stays visible
    layout = {"margin": {"l": 0, "r": 0, "t": 10, "b": 0},
              "scene": {"aspectmode": "manual", "aspectratio": dict(zip("xyz", map(float, ratio))),
                        "xaxis": {"title": {"text": "x (mm)"}},
                        "yaxis": {"title": {"text": "y (mm)"}},
                        "zaxis": {"title": {"text": "z (mm)"}, "nticks": 4},
                        # seen from the camera's side (camera at the origin looking along +z, image y down)
                        "camera": {"up": {"x": 0, "y": -1, "z": 0}, "eye": {"x": 0.5, "y": -0.5, "z": -1.7}}}}
    return (f"(function(){{const d={json.dumps(data)};const x=u16(d.x,d.x0,d.dx),y=u16(d.y,d.y0,d.dy),"
            "z=u16(d.z,d.z0,d.dz);"
            "Plotly.newPlot(" + json.dumps(div) + ",[{type:'scatter3d',mode:'markers',x:x,y:y,z:z,"
            "marker:{size:1.5,color:z,colorscale:'Viridis',colorbar:{title:{text:'z (mm)'}}}}],"
            f"{json.dumps(layout)},{{responsive:true,displaylogo:false}});}})();")


def build_page(c: FolderContents, table, css: str, plotly_js: str) -> str:
    """HTML text of the report of ``c`` (``table(rows, header, cls)`` renders a table)."""
    title = f"fringe3d report: {c.name or c.folder.resolve().name}"
    cal_prov = ((c.calibration or {}).get("provenance"), str(c.calibration_source)) if c.calibration else None
    parts = [f"<h1>{html.escape(title)}</h1>", "<h2>Provenance</h2>",
             table(provenance_rows(c.marker, cal_prov), ["item", "value"], "provenance")]
    scripts = [JS_DECODE]
    if c.calibration is not None:
        parts.append(f"<h2>Calibration</h2><p class='muted'>from {html.escape(str(c.calibration_source))}</p>")
        for t, header, rows in calibration_tables(c.calibration):
            parts.append(f"<h3>{html.escape(t)}</h3><div class='scroll'>{table(rows, header, 'calibration')}</div>")
    if c.merge is not None:
        mv_parts, mv_scripts = multiview_parts(c.merge, c.evaluation, table)
        parts += mv_parts
        scripts += mv_scripts
    if c.evaluation:
        parts += evaluation_parts(c.evaluation, table)
    parts += radiometry_parts(c, table)
    if c.maps:
        parts.append("<h2>Error and quality maps</h2><div class='maps'>")
        for i, m in enumerate(c.maps):
            fig, script = map_figure(m, f"map_{i}")
            parts.append(fig)
            scripts.append(script)
        parts.append("</div>")
    if c.points is not None:
        n = int(np.isfinite(np.asarray(c.points)).all(axis=-1).sum())
        parts.append(f"<h2>3D points</h2><p class='muted'>{html.escape(str(c.points_source))}: {n} valid points"
                     f"{f', {MAX_POINTS_3D} shown' if n > MAX_POINTS_3D else ''}</p>"
                     '<div id="plot3d_0" class="plot3d"></div>')
        scripts.append(points_script(c.points, "plot3d_0"))
    if c.strain is not None:
        n = len(c.strain["t"])
        parts.append("<h2>Strain over time</h2><p class='muted'>dominant principal strain of the tracked points per "
                     f"frame ({n} frames): median and 5-95 % band, microstrain; the map below is the frame of "
                     f"largest strain ({c.strain['peak_frame']}); every frame: maps/, strain.gif, strain.pvd</p>"
                     '<div id="strain_0" class="strainplot"></div>')
        scripts.append(strain_script(c.strain, "strain_0"))
    for p in c.pngs:
        data = base64.b64encode(p.read_bytes()).decode()
        parts.append(f"<h3>{html.escape(p.name)}</h3>"
                     f'<img class="fig" alt="{html.escape(p.name)}" src="data:image/png;base64,{data}">')
    for name, summ in c.summaries.items():
        parts.append(f"<h2>{html.escape(name)}</h2><div class='scroll'>"
                     + table(summary_rows(summ), ["field", "value", "unit"], "summary") + "</div>")
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(title)}</title><style>{css}{PAGE_CSS}</style>"
            f"{loader_script(plotly_js)}</head><body>"
            + "\n".join(parts)
            + "<p class='muted'>fringe3d report · self-contained, no network needed</p>"
            + f"{draw_script(''.join(scripts))}</body></html>")
