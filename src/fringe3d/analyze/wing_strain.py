"""A wing-strain run from a point-map sequence to files (dissertation ch. 6): anchors ->
geodesic tracking (Eq. 6.9) -> Kirchhoff-Love bending strain (Eq. 6.10-6.21) -> CSV, VTK,
PNG maps, GIF and a JSON summary. ``fringe3d strain`` is this function plus printing."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from fringe3d.io.export_vtk import grid_triangles, strain_table, write_strain_csv, write_strain_frame, write_strain_pvd
from fringe3d.io.point_sequence import read_point_sequence
from fringe3d.io.strain_figures import (
    scatter_to_image,
    strain_animation,
    strain_map_png,
)
from fringe3d.utils.console import progress_bar
from fringe3d.utils.jsonfile import write_json

from .anchors import (
    auto_anchors,
    check_anchor,
    fill_dot_holes,
    follow_anchors,
    parse_anchors,
    query_grid,
)
from .strain import wing_sequence


class _StrainImages:
    """The per-frame dominant-strain images (H, W) float, NaN off the wings, drawn on demand from
    the tracked points (so the GIF does not hold F full-resolution maps in memory)."""

    def __init__(self, results, shape, radius: int, frames: int):
        self.results, self.shape, self.radius, self.frames = results, shape, radius, frames

    def __len__(self) -> int:
        return self.frames

    def __getitem__(self, f: int) -> np.ndarray:
        if not 0 <= f < self.frames:
            raise IndexError(f)
        img = np.full(self.shape, np.nan)
        for r in self.results:
            part = scatter_to_image(r.uv[f][r.ok[f]], r.dominant[f][r.ok[f]], self.shape, radius=self.radius)
            img = np.where(np.isfinite(part), part, img)
        return img


def run_strain(sequence, anchors: str, out: Path, thickness: float = 0.1, window: int = 11, step: int = 4,
               wings: int = 1, radius: int = 3, reference: int = 0, figures: bool = True, fill_dots: int = 8) -> dict:
    """Track a wing sequence and map its bending strain (Eq. 6.9-6.21): everything
    ``fringe3d strain`` does; returns the JSON summary. Validates all inputs before any file
    is written (``strain.csv``, ``vtk/frame_*.vtu`` + ``strain.pvd``, ``maps/strain_*.png``, ``strain.gif``,
    ``summary.json`` in ``out``, each atomically)."""
    t0 = time.perf_counter()
    if not (thickness > 0):
        raise ValueError(f"--thickness must be > 0 mm; got {thickness}")
    if window < 3 or window % 2 == 0:
        raise ValueError(f"--window must be an odd number of pixels ≥ 3; got {window}")
    if step < 1:
        raise ValueError(f"--step must be ≥ 1 pixel; got {step}")
    start = parse_anchors(anchors)
    seq = read_point_sequence(sequence)
    if not (0 <= reference < len(seq)):
        raise ValueError(f"--reference {reference} is outside the sequence's {len(seq)} frames")
    if start is None:
        start = auto_anchors(seq, wings)
    ref = seq[reference]
    for a in start:
        filled = fill_dot_holes(ref, a, fill_dots) if fill_dots > 0 else ref
        for x in a:
            check_anchor(filled, x)
    per_frame = follow_anchors(seq.texture if seq.has_texture else None, len(seq), start)
    results = []
    with progress_bar("tracking + strain", total=len(seq) * len(start)) as advance:
        for w, a in enumerate(start):
            q = query_grid(ref, a, step, margin=window // 2)
            if len(q) == 0:
                raise ValueError(f"wing {w}: no surface pixels around the anchors to track")
            # frames streamed: wing_sequence reads seq[i] (checked shape, float64) one at a time
            results.append(wing_sequence(seq, per_frame[:, w], q, thickness, window, reference, radius=radius,
                                         fill_dots=fill_dots, progress=advance))
    # outputs (each file atomic)
    out = Path(out)
    tables, frame_col, wing_col = [], [], []
    for f in range(len(seq)):
        for w, r in enumerate(results):
            tab = strain_table(r.xyz[f], r.E[f], r.principal[f], r.dominant[f], r.uv[f], r.residual[f], r.ok[f])
            tables.append(tab)
            frame_col.append(np.full(len(tab), f))
            wing_col.append(np.full(len(tab), w))
    write_strain_csv(out / "strain.csv", np.vstack(tables), np.concatenate(frame_col), np.concatenate(wing_col))
    frame_files = []
    for f in range(len(seq)):
        frame_tab = np.vstack([tables[f * len(results) + w] for w in range(len(results))])
        offsets = np.cumsum([0] + [len(r.ref_uv) for r in results])
        tri = np.concatenate([grid_triangles(r.ref_uv, step, r.ok[f] & np.isfinite(r.xyz[f]).all(axis=-1)) + o
                              for r, o in zip(results, offsets)])
        frame_files.append(write_strain_frame(out / "vtk" / f"frame_{f:05d}.vtu", frame_tab, tri))
    write_strain_pvd(out / "strain.pvd", frame_files)
    if figures:
        allv = np.concatenate([np.abs(r.dominant[r.ok]) for r in results])
        vmax = float(np.percentile(allv, 99)) if allv.size else 1e-6
        images = _StrainImages(results, seq.shape[:2], max(step // 2, 1), len(seq))
        for f in range(len(seq)):
            strain_map_png(out / "maps" / f"strain_{f:05d}.png", images[f], f"dominant bending strain, frame {f}",
                           vmax)
        strain_animation(out / "strain.gif", images, [f"frame {f}" for f in range(len(seq))], vmax)
    summary = {
        "frames": len(seq), "wings": len(results), "points_per_wing": [int(len(r.ref_uv)) for r in results],
        "tracked_fraction": float(np.mean(np.concatenate([r.ok.ravel() for r in results]))),
        "median_residual_mm": float(np.nanmedian(np.concatenate([r.residual[r.ok] for r in results]))),
        "dominant_strain_p99": float(np.nanpercentile(np.concatenate([np.abs(r.dominant[r.ok]) for r in results]), 99)),
        "thickness_mm": thickness, "window_px": window, "step_px": step, "geodesic_window_px": 2 * radius + 1,
        "seconds": round(time.perf_counter() - t0, 2), "output": str(out),
    }
    write_json(out / "summary.json", summary, units={"median_residual_mm": "mm", "thickness_mm": "mm",
                                                     "dominant_strain_p99": "1 (strain)", "window_px": "px",
                                                     "step_px": "px", "geodesic_window_px": "px", "seconds": "s"})
    return summary
