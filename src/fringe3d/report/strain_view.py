"""Strain over time for the report of a ``fringe3d strain`` folder: one plot instead of a stack of
per-frame maps.

Reads ``arrays/wing_K/dominant.npy`` (F, N) (dominant principal Green-Lagrange strain, 1) and
``ok.npy`` (F, N) (tracked points). Per frame and wing: the median and the 5th-95th percentile
band of the tracked points' strain, in microstrain (1e-6). Time is ``frame / frame_rate_hz``
(s) when ``summary.json`` names the rate, else the frame index.
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

MICRO = 1e6


def strain_series(folder: Path, frame_rate_hz: float | None) -> dict | None:
    """``{"t": [...], "t_title": str, "wings": {name: {"median", "p5", "p95"}}, "peak_frame": int}``
    (strain in microstrain, NaN where a frame tracked no point), or None without strain arrays."""
    wings = {}
    peak = None
    t = None
    for d in sorted((folder / "arrays").glob("wing_*")):
        if not ((d / "dominant.npy").is_file() and (d / "ok.npy").is_file()):
            continue
        e = np.load(d / "dominant.npy").astype(np.float64) * MICRO
        ok = np.load(d / "ok.npy").astype(bool) & np.isfinite(e)
        if e.ndim != 2 or ok.shape != e.shape:
            continue
        masked = np.where(ok, e, np.nan)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a frame that tracked nothing stays NaN
            stats = {k: np.nanpercentile(masked, q, axis=1) for k, q in (("median", 50), ("p5", 5), ("p95", 95))}
            amp = np.nanmax(np.abs(masked), axis=1)
        wings[d.name] = {k: [None if not np.isfinite(x) else float(x) for x in v] for k, v in stats.items()}
        if peak is None and np.isfinite(amp).any():
            peak = int(np.nanargmax(amp))
        n = e.shape[0]
        t = np.arange(n) / frame_rate_hz if frame_rate_hz else np.arange(n, dtype=float)
    if not wings or t is None:
        return None
    return {"t": t.tolist(), "t_title": "time (s)" if frame_rate_hz else "frame (no frame rate given)",
            "wings": wings, "peak_frame": peak or 0}


def strain_script(series: dict, div: str) -> str:
    """JavaScript drawing :func:`strain_series` in ``div``: a band and a median line per wing."""
    traces = []
    for i, (name, s) in enumerate(series["wings"].items()):
        colour = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")[i % 4]
        traces += [{"x": series["t"], "y": s["p95"], "mode": "lines", "line": {"width": 0}, "showlegend": False,
                    "hoverinfo": "skip", "legendgroup": name},
                   {"x": series["t"], "y": s["p5"], "mode": "lines", "line": {"width": 0}, "fill": "tonexty",
                    "fillcolor": colour + "33", "name": f"{name} 5-95 %", "legendgroup": name},
                   {"x": series["t"], "y": s["median"], "mode": "lines+markers", "line": {"color": colour},
                    "name": f"{name} median", "legendgroup": name}]
    layout = {"margin": {"l": 64, "r": 10, "t": 10, "b": 48},
              "xaxis": {"title": {"text": series["t_title"]}},
              "yaxis": {"title": {"text": "dominant strain (µε)"}},
              "legend": {"orientation": "h", "y": -0.25}}
    return (f"Plotly.newPlot({json.dumps(div)},{json.dumps(traces)},{json.dumps(layout)},"
            "{responsive:true,displaylogo:false});")
