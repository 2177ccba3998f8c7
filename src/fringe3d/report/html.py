"""One self-contained HTML page per results folder: no network needed to view it.

Plotly's JavaScript bundle is inlined once; images are embedded as base64 data URIs and point
clouds as base64 float32 arrays (:mod:`.typed`). A folder
with a ``summary.json`` that has a ``title`` (``fringe3d demo``) gets the demo page; any other
output (decode, reconstruct + evaluate, calibrate, strain) gets the page :mod:`.page` builds
from what :mod:`.discover` finds.
"""
from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_write_text
from fringe3d.io.arrays import load_array

from fringe3d.utils.output_folder import read_marker

from .page import build_page, points_script, provenance_rows
from .plotly_bundle import draw_script, loader_script
from .results import SUMMARY_NAME, load_summary
from .typed import JS_DECODE


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;font-size:16px;line-height:1.45;
margin:2em auto;max-width:1100px;padding:0 1em;color:#222;box-sizing:border-box}
h1{font-size:1.6em} h2{border-bottom:1px solid #ddd;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.6em 0} th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#f3f3f3} td:first-child,th:first-child{text-align:left}
.fig{max-width:100%;height:auto;border:1px solid #eee} .plot3d{width:100%;height:520px}
@media (max-width:900px){body{margin:1em auto;font-size:15px} .plot3d{height:420px}}
.muted{color:#777;font-size:.9em} table.provenance td,table.provenance th{text-align:left}
"""


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            return "—"
        a = abs(v)
        return f"{v:.3g}" if a and (a < 1e-3 or a >= 1e5) else f"{v:.4g}"
    return html.escape(str(v))


def _table(rows: list[list], header: list[str], cls: str = "") -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_fmt(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f'<table class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _img(folder: Path, name: str | None, alt: str) -> str:
    if not name:
        return ""
    p = folder / name
    if not p.exists():
        return f'<p class="muted">figure {html.escape(name)} missing</p>'
    data = base64.b64encode(p.read_bytes()).decode()
    return f'<img class="fig" alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def accuracy_table(accuracy: list[dict]) -> str:
    """The accuracy table: quantity, value, unit, then the ``truth`` and ``dissertation`` columns
    only when some row has one (a column of blanks or zeros says nothing)."""
    cols = ["quantity", "value", "unit"] + [k for k in ("truth", "dissertation")
                                            if any(a.get(k) not in (None, "") for a in accuracy)]
    rows = [[a.get(k, "") if a.get(k) is not None else "—" for k in cols] for a in accuracy]
    return _table(rows, cols, "accuracy")


#: Fields that make a ``summary.json`` a demo summary (``fringe3d strain`` writes other ones).
DEMO_FIELDS = {"title", "stages", "measurements", "accuracy", "calibration"}


def is_demo_folder(folder: Path) -> bool:
    """Whether ``folder`` holds a demo-style ``summary.json``: a JSON object with a ``title`` or any
    other field of :class:`~fringe3d.report.results.SummaryModel` (then :func:`load_summary` checks it,
    so a demo summary that lost its title is refused by name instead of reported as a plain folder)."""
    path = Path(folder) / SUMMARY_NAME
    if not path.is_file():
        return False
    try:
        d = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError):
        return True  # let load_summary name the damage
    return isinstance(d, dict) and bool(DEMO_FIELDS & set(d))


def build_report(folder: str | Path) -> str:
    """Return the HTML text of the report for a results folder (or a calibration JSON).

    Parameters
    ----------
    folder : str or Path
        A results folder (decode, reconstruct, evaluate, experiment) or a calibration JSON.

    Returns
    -------
    str
        A self-contained HTML page.
    """
    import plotly.offline  # heavy (~1 s): only when a report is built

    folder = Path(folder)
    if not is_demo_folder(folder):
        from .discover import discover

        return build_page(discover(folder), _table, _CSS, plotly.offline.get_plotlyjs())
    s = load_summary(folder)
    parts = [f"<h1>{html.escape(s['title'])}</h1>"]
    if s.get("subtitle"):
        parts.append(f'<p class="muted">{html.escape(s["subtitle"])}</p>')

    marker = read_marker(folder)  # the demo writes its report before it marks the folder complete
    marker = {k: v for k, v in marker.items() if k not in ("complete", "finished", "files")} if marker else None
    parts.append("<h2>Provenance</h2>" + _table(provenance_rows(marker), ["item", "value"], "provenance"))
    if s.get("accuracy"):
        parts.append("<h2>Accuracy</h2>" + accuracy_table(s["accuracy"]))

    cal = s.get("calibration")
    if cal:
        parts.append("<h2>Calibration</h2>")
        figs = cal.get("figures", {})
        if figs:
            parts.append(_table([[k, v] for k, v in figs.items()], ["figure", "value"], "calibration"))
        poses = cal.get("poses", [])
        if poses:
            keys = list(poses[0].keys())
            parts.append(_table([[p.get(k) for k in keys] for p in poses], keys, "poses"))
        parts.append(_img(folder, cal.get("residual_plot"), "calibration residuals"))

    plots = []
    for i, m in enumerate(s.get("measurements", [])):
        parts.append(f"<h2>Measurement: {html.escape(m['name'])}</h2>")
        if m.get("metrics"):
            parts.append(_table([[k, v] for k, v in m["metrics"].items()], ["metric", "value"], "metrics"))
        if m.get("points") and (folder / m["points"]).exists():
            div = f"plot3d_{i}"
            parts.append(f'<div id="{div}" class="plot3d"></div>')
            plots.append(points_script(load_array(folder / m["points"], "point map"), div))
        parts.append(_img(folder, m.get("error_map"), f"error map {m['name']}"))

    for name, seq in s.get("sequences", {}).items():
        parts.append(f"<h2>Sequence: {html.escape(name)}</h2>")
        goals = seq.get("goals", {})
        if goals:
            parts.append(_table([[k, bool(v)] for k, v in goals.items()], ["goal", "met"], "goals"))
        for tab in seq.get("tables", []):
            parts.append(f"<h3>{html.escape(str(tab.get('title', '')))}</h3>"
                         + _table(tab.get("rows", []), tab.get("columns", []), "sequence"))

    if s.get("stages"):
        rows = [[st["name"], st.get("seconds", float("nan"))] for st in s["stages"]]
        parts.append("<h2>Time per stage</h2>" + _table(rows, ["stage", "seconds"], "stages"))

    scripts = JS_DECODE + "".join(plots)
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(s['title'])}</title><style>{_CSS}</style>"
            f"{loader_script(plotly.offline.get_plotlyjs())}</head><body>"
            + "\n".join(parts)
            + "<p class='muted'>fringe3d report · self-contained, no network needed</p>"
            + f"{draw_script(scripts)}</body></html>")


def default_output(results: Path) -> Path:
    """``RESULTS/report.html`` for a folder, ``RESULTS.html`` beside a file."""
    return results.with_suffix(".html") if results.is_file() else results / "report.html"


def write_report(folder: str | Path, out: str | Path | None = None) -> Path:
    """Build the report for ``folder`` and write it atomically.

    Parameters
    ----------
    folder : str or Path
        As in :func:`build_report`.
    out : str or Path, optional
        The HTML file; default ``folder/report.html``, or ``NAME.html`` beside a calibration JSON.

    Returns
    -------
    Path
        The file written.
    """
    folder = Path(folder)
    out = Path(out) if out else default_output(folder)
    atomic_write_text(out, build_report(folder))
    return out
