"""One (H, W) map of a results folder as a plotly heatmap a reviewer can read.

* Axes count **full-resolution camera pixels** (u right, v down) even when the page carries a
  preview reduced by ``k`` (every k-th pixel, :func:`~.typed.shrink_map`): the preview's samples
  sit at ``u = k * j`` (``x0 = 0``, ``dx = k``) and the axis range is ``[-0.5, W - 0.5]``; the
  caption says "preview reduced k×".
* Continuous maps get **robust colour limits**: the 1st and 99th percentiles of the finite
  values (NaN background left out), symmetric ``±P99(|v|)`` for signed maps on a diverging scale
  centred on 0, so a few outliers or a huge background do not flatten the object to one colour.
* Discrete maps (the valid mask, the quality reason bits of :mod:`fringe3d.decode.edges`) are
  drawn as categories with one colour each and a labelled legend (a stepped colour bar), not a
  continuous bar.
* The title is an HTML caption above the plot, so plotly's toolbar (top right of the plot area)
  can never cover it.
"""
from __future__ import annotations

import html
import json

import numpy as np

from fringe3d.decode.edges import BITS

from .typed import b64_float32, shrink_map

MAX_MAP_SIDE = 400
#: Category colours (ok / valid first).
PALETTE = ("#2ca02c", "#d62728", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#1f77b4")
MASK_LABELS = ("invalid", "valid")


def robust_limits(values: np.ndarray, centred: bool) -> tuple[float, float] | None:
    """Colour limits of a continuous map: ``(P1, P99)`` of its finite values, or ``(-a, a)`` with
    ``a = P99(|v|)`` when ``centred``; None when no value is finite."""
    finite = values[np.isfinite(values)]
    if not finite.size:
        return None
    if centred:
        a = float(np.percentile(np.abs(finite), 99)) or float(np.max(np.abs(finite))) or 1.0
        return -a, a
    lo, hi = (float(x) for x in np.percentile(finite, [1, 99]))
    return (lo, hi) if hi > lo else (lo - 0.5, lo + 0.5)


def quality_categories(q: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Category of each pixel of a uint8 quality map: 0 "ok" (no bit), else the first reason bit
    set (lowest value, :data:`fringe3d.decode.edges.BITS`); returns ``(categories, labels)``."""
    q = np.nan_to_num(np.asarray(q, np.float64), nan=0).astype(np.uint8)
    cat = np.zeros(q.shape, np.float32)
    labels = ["ok"]
    for i, (bit, name) in enumerate(sorted(BITS.items())):
        first = ((q & bit) > 0) & (cat == 0)
        cat[first] = i + 1
        labels.append(name)
    return cat, labels


def _discrete(values: np.ndarray, kind: str) -> tuple[np.ndarray, list[str], dict]:
    """Category map, labels and the trace fields of a stepped colour bar (only categories present)."""
    if kind == "mask":
        cat, labels = (np.nan_to_num(values) > 0).astype(np.float32), list(MASK_LABELS)
        colours = ["#444444", "#2ca02c"]
    else:
        cat, labels = quality_categories(values)
        colours = list(PALETTE)
    present = [i for i in range(len(labels)) if np.any(cat == i)] or [0]
    remap = np.full(len(labels), np.nan, np.float32)
    remap[present] = np.arange(len(present))
    n = len(present)
    scale = []
    for j, i in enumerate(present):
        scale += [[j / n, colours[i % len(colours)]], [(j + 1) / n, colours[i % len(colours)]]]
    fields = {"colorscale": scale, "zmin": -0.5, "zmax": n - 0.5,
              "colorbar": {"tickvals": list(range(n)), "ticktext": [labels[i] for i in present],
                           "title": {"text": "category"}, "len": 0.9}}
    return remap[cat.astype(int)], [labels[i] for i in present], fields


def map_figure(m, div: str) -> tuple[str, str]:
    """``(html, script)`` of map ``m`` (a :class:`~.discover.MapItem`) in the element ``div``."""
    H, W = m.values.shape
    v = shrink_map(m.values, MAX_MAP_SIDE)
    k = max(1, -(-max(H, W) // MAX_MAP_SIDE))
    trace: dict = {"type": "heatmap", "hoverongaps": False, "x0": 0, "dx": k, "y0": 0, "dy": k}
    legend = ""
    if m.discrete:
        v, labels, fields = _discrete(v, m.discrete)
        trace.update(fields)
        legend = f" · {len(labels)} categories"
    else:
        trace.update(colorscale=m.colorscale, colorbar={"title": {"text": m.unit, "side": "right"}})
        lim = robust_limits(v, m.centred)
        if lim:
            trace.update(zmin=lim[0], zmax=lim[1])
    h, w = v.shape
    layout = {"margin": {"l": 56, "r": 10, "t": 10, "b": 44},
              "xaxis": {"title": {"text": "u (camera px)"}, "range": [-0.5, W - 0.5], "constrain": "domain",
                        "zeroline": False},
              "yaxis": {"title": {"text": "v (camera px)"}, "range": [H - 0.5, -0.5], "scaleanchor": "x",
                        "constrain": "domain", "zeroline": False}}
    note = f"{W} × {H} camera px" + (f", preview reduced {k}×" if k > 1 else "")
    unit = f" ({m.unit})" if m.unit and not m.discrete else ""
    cap = (f'<figure class="map"><figcaption class="maptitle">{html.escape(m.title + unit)}'
           f'<span class="muted"> · {html.escape(m.name)} · {note}{html.escape(legend)}</span></figcaption>'
           f'<div id="{div}" class="mapplot" title="{html.escape(m.name)}"></div></figure>')
    script = (f"(function(){{const t={json.dumps(trace)};t.z=grid({json.dumps(b64_float32(v))},{h},{w});"
              f"Plotly.newPlot({json.dumps(div)},[t],{json.dumps(layout)},"
              "{responsive:true,displaylogo:false});})();")
    return cap, script
