"""``fringe3d strain``: track a wing through a 3D sequence and map its bending strain (ch. 6).

SEQUENCE is one of
* a folder of per-frame point maps ``points_00000.npy`` … ((H, W, 3) float, mm, NaN invalid),
  optionally with textures ``texture_00000.npy`` / ``.png`` (for ``--anchors auto``);
* a single ``.npy`` / ``.npz`` holding ``points`` (F, H, W, 3) (and optionally ``texture``);
* a zarr store (folder) with arrays ``points`` (F, H, W, 3) and optionally ``texture`` (F, H, W)
  and ``done`` (F,) completion flags (:class:`fringe3d.io.store.PointMapStore`), or a folder
  holding such a ``points.zarr``.

Outputs in OUT (each written atomically, and only after every input check has passed):
``strain.csv`` (all frames, wings and points), ``vtk/frame_00000.vtk`` (one legacy VTK polydata
per frame), ``maps/strain_00000.png`` (dominant strain maps with a colour bar),
``strain.gif`` (animation) and ``summary.json``.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import typer

from fringe3d.utils.console import (
    console,
    make_table,
    print_json,
    progress_bar,
    set_quiet,
)
from fringe3d.utils.jsonfile import write_json

MIN_FRAMES = 2


# --- reading a sequence ---------------------------------------------------------------------------
class PointSequence:
    """Lazy, validated list of point maps (F frames of (H, W, 3) float) with optional textures."""

    def __init__(self, loaders, texture_loaders, shape, source: str):
        self._load, self._tex, self.shape, self.source = loaders, texture_loaders, shape, source

    def __len__(self) -> int:
        return len(self._load)

    def __getitem__(self, i: int) -> np.ndarray:
        a = np.asarray(self._load[i](), dtype=np.float64)
        if a.shape != self.shape:
            raise ValueError(f"frame {i} of {self.source} has shape {a.shape}; expected {self.shape} like frame 0")
        return a

    @property
    def has_texture(self) -> bool:
        return self._tex is not None

    def texture(self, i: int) -> np.ndarray:
        if self._tex is None:
            raise ValueError(f"{self.source} holds no texture images; pass --anchors u1,v1,u2,v2")
        return np.asarray(self._tex[i](), dtype=np.float64)


def _check_shape(shape, what):
    if len(shape) != 3 or shape[2] != 3:
        raise ValueError(f"{what} has shape {tuple(shape)}; expected an organized point map (H, W, 3) in mm")


def read_point_sequence(path: str | Path) -> PointSequence:
    """Open SEQUENCE (see the module docstring). Checks that every frame exists, has the same
    (H, W, 3) shape, and that there are at least two frames; raises ``FileNotFoundError`` /
    ``ValueError`` saying what was expected."""
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"sequence {p} does not exist; expected a folder of points_*.npy, a .npy/.npz "
                                "with 'points' (F, H, W, 3), or a zarr store")
    tex = None
    if p.is_dir() and (p / "points.zarr").is_dir() and not list(p.glob("points_*.npy")):
        p = p / "points.zarr"   # the output folder of ``fringe3d reconstruct`` sequences
    if p.is_file():
        if p.suffix == ".npz":
            z = np.load(p)
            if "points" not in z:
                raise ValueError(f"{p} has no 'points' array; found {sorted(z.files)}")
            arr = z["points"]
            tex_arr = z["texture"] if "texture" in z else None
        elif p.suffix == ".npy":
            arr, tex_arr = np.load(p, mmap_mode="r"), None
        else:
            raise ValueError(f"unsupported sequence file {p.name}; expected .npy, .npz or a folder")
        if arr.ndim != 4:
            raise ValueError(f"{p} holds shape {arr.shape}; expected (frames, H, W, 3)")
        loaders = [lambda i=i: arr[i] for i in range(arr.shape[0])]
        if tex_arr is not None:
            tex = [lambda i=i: tex_arr[i] for i in range(tex_arr.shape[0])]
        shape = tuple(arr.shape[1:])
    elif (p / ".zgroup").exists() or (p / "zarr.json").exists() or (p / ".zarray").exists():
        import zarr
        store = zarr.open(str(p), mode="r")
        if hasattr(store, "shape"):
            arr, tex_arr = store, None
        else:
            if "points" not in store:
                raise ValueError(f"zarr store {p} has no 'points' array; found {sorted(store.keys())}")
            arr = store["points"]
            tex_arr = store["texture"] if "texture" in store else None
            if "done" in store:
                missing = np.flatnonzero(np.asarray(store["done"][:]) == 0)
                if missing.size:
                    raise ValueError(f"zarr store {p} is incomplete: frame(s) {missing[:10].tolist()} were never "
                                     "written; finish (resume) the reconstruction first")
        if len(arr.shape) != 4:
            raise ValueError(f"zarr array in {p} has shape {arr.shape}; expected (frames, H, W, 3)")
        loaders = [lambda i=i: arr[i] for i in range(arr.shape[0])]
        if tex_arr is not None:
            tex = [lambda i=i: tex_arr[i] for i in range(tex_arr.shape[0])]
        shape = tuple(arr.shape[1:])
    else:
        files = sorted(p.glob("points_*.npy"))
        if not files:
            raise FileNotFoundError(f"no points_*.npy files in {p}; expected per-frame point maps "
                                    "points_00000.npy … (H, W, 3) mm")
        shapes = [np.load(f, mmap_mode="r").shape for f in files]
        _check_shape(shapes[0], files[0].name)
        for f, s in zip(files, shapes):
            if s != shapes[0]:
                raise ValueError(f"frames differ in size: {f.name} is {s}, {files[0].name} is {shapes[0]}; "
                                 "expected every frame from the same camera")
        loaders = [lambda f=f: np.load(f) for f in files]
        shape = tuple(shapes[0])
        tfiles = [f.with_name(f.name.replace("points_", "texture_")) for f in files]
        tpng = [t.with_suffix(".png") for t in tfiles]
        if all(t.exists() for t in tfiles):
            tex = [lambda t=t: np.load(t) for t in tfiles]
        elif all(t.exists() for t in tpng):
            from fringe3d.io.images import read_image
            tex = [lambda t=t: read_image(t) for t in tpng]
    _check_shape(shape, str(p))
    if len(loaders) < MIN_FRAMES:
        raise ValueError(f"sequence {p} has {len(loaders)} frame(s); expected at least {MIN_FRAMES} "
                         "(a reference frame and a deformed one)")
    if tex is not None and len(tex) != len(loaders):
        raise ValueError(f"{p} has {len(tex)} textures for {len(loaders)} point maps; expected one per frame")
    return PointSequence(loaders, tex, shape, str(p))


# --- anchors --------------------------------------------------------------------------------------
def parse_anchors(text: str) -> list[np.ndarray] | None:
    """``"auto"`` → None; ``"u1,v1,u2,v2[;u3,v3,u4,v4]"`` → list of (2, 2) arrays (one per wing)."""
    if text.strip().lower() == "auto":
        return None
    wings = []
    for part in text.split(";"):
        try:
            vals = [float(x) for x in part.split(",")]
        except ValueError:
            raise ValueError(f"cannot read anchors {part!r}; expected 'u1,v1,u2,v2' (pixels) or 'auto'") from None
        if len(vals) != 4:
            raise ValueError(f"anchors {part!r} has {len(vals)} numbers; expected 4: u1,v1,u2,v2")
        wings.append(np.array(vals).reshape(2, 2))
    return wings


def follow_anchors(texture, n_frames: int, start: list[np.ndarray], search: float = 40.0) -> np.ndarray:
    """Anchor positions (F, wings, 2, 2) from the reference positions ``start``.

    ``texture``: callable ``i -> (H, W)`` image, or None. With textures, each frame's anchor is
    the dark dot nearest its constant-velocity prediction (within ``search`` px, else the
    prediction); without, the given positions hold for every frame (anchors near the wing root
    barely move)."""
    from fringe3d.analyze.anchors import dark_dots

    out = np.repeat(np.stack(start)[None], n_frames, axis=0)
    if texture is None:
        return out
    for f in range(1, n_frames):
        try:
            dots = dark_dots(texture(f))[:, :2]
        except ValueError:
            dots = np.empty((0, 2))
        for w in range(len(start)):
            for a in range(2):
                pred = out[f - 1, w, a] + ((out[f - 1, w, a] - out[f - 2, w, a]) if f >= 2 else 0.0)
                out[f, w, a] = pred
                if len(dots):
                    d = np.linalg.norm(dots - pred, axis=1)
                    j = int(np.argmin(d))
                    if d[j] <= search:
                        out[f, w, a] = dots[j]
    return out


def auto_anchors(seq: PointSequence, wings: int) -> list[np.ndarray]:
    """Detect 2 × ``wings`` dark dots in the reference texture and pair them per wing."""
    from fringe3d.analyze.anchors import find_anchor_dots, pair_anchors

    if not seq.has_texture:
        raise ValueError(f"--anchors auto needs texture images in {seq.source} (texture_00000.npy/.png or a "
                         "'texture' array); none found. Pass --anchors u1,v1,u2,v2 instead")
    dots = find_anchor_dots(seq.texture(0), count=2 * wings)
    return pair_anchors(dots, seq[0]) if wings > 1 else [dots]


def query_grid(points: np.ndarray, anchors: np.ndarray, step: int, margin: int) -> np.ndarray:
    """Reference pixels (N, 2) every ``step`` px on the surface region that holds the anchors,
    at least ``margin`` px inside its valid area."""
    from scipy import ndimage
    from skimage import measure

    valid = np.isfinite(points).all(axis=2)
    lab = measure.label(valid, connectivity=1)
    region = lab == lab[int(round(anchors[0, 1])), int(round(anchors[0, 0]))]
    if margin > 0:
        region = ndimage.binary_erosion(region, iterations=margin)
    v, u = np.mgrid[0:valid.shape[0]:step, 0:valid.shape[1]:step]
    keep = region[v, u]
    return np.stack([u[keep], v[keep]], axis=1).astype(float)


# --- the command ----------------------------------------------------------------------------------
def run_strain(sequence, anchors: str, out: Path, thickness: float = 0.1, window: int = 11, step: int = 4,
               wings: int = 1, radius: int = 3, reference: int = 0, figures: bool = True, fill_dots: int = 8) -> dict:
    """Everything ``fringe3d strain`` does; returns the JSON summary. Validates all inputs
    before any file is written."""
    from fringe3d.analyze.anchors import check_anchor
    from fringe3d.analyze.strain import wing_sequence
    from fringe3d.io.export_vtk import strain_table, write_strain_csv, write_strain_vtk
    from fringe3d.io.strain_figures import (
        scatter_to_image,
        strain_animation,
        strain_map_png,
    )

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
    from fringe3d.analyze.anchors import fill_dot_holes
    ref = seq[reference]
    for a in start:
        filled = fill_dot_holes(ref, a, fill_dots) if fill_dots > 0 else ref
        for x in a:
            check_anchor(filled, x)
    per_frame = follow_anchors(seq.texture if seq.has_texture else None, len(seq), start)
    maps = [seq[i] for i in range(len(seq))]  # loads and checks every frame's shape up front
    results = []
    with progress_bar("tracking + strain", total=len(seq) * len(start)) as advance:
        for w, a in enumerate(start):
            q = query_grid(ref, a, step, margin=window // 2)
            if len(q) == 0:
                raise ValueError(f"wing {w}: no surface pixels around the anchors to track")
            results.append(wing_sequence(maps, per_frame[:, w], q, thickness, window, reference, radius=radius,
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
    for f in range(len(seq)):
        frame_tab = np.vstack([tables[f * len(results) + w] for w in range(len(results))])
        write_strain_vtk(out / "vtk" / f"frame_{f:05d}.vtk", frame_tab, title=f"fringe3d strain frame {f}")
    if figures:
        allv = np.concatenate([np.abs(r.dominant[r.ok]) for r in results])
        vmax = float(np.percentile(allv, 99)) if allv.size else 1e-6
        images = []
        for f in range(len(seq)):
            img = np.full(seq.shape[:2], np.nan)
            for r in results:
                part = scatter_to_image(r.uv[f][r.ok[f]], r.dominant[f][r.ok[f]], seq.shape[:2], radius=max(step // 2, 1))
                img = np.where(np.isfinite(part), part, img)
            images.append(img)
            strain_map_png(out / "maps" / f"strain_{f:05d}.png", img, f"dominant bending strain, frame {f}", vmax)
        strain_animation(out / "strain.gif", images, [f"frame {f}" for f in range(len(seq))], vmax)
    summary = {
        "frames": len(seq), "wings": len(results), "points_per_wing": [int(len(r.ref_uv)) for r in results],
        "tracked_fraction": float(np.mean(np.concatenate([r.ok.ravel() for r in results]))),
        "median_residual_mm": float(np.nanmedian(np.concatenate([r.residual[r.ok] for r in results]))),
        "dominant_strain_p99": float(np.nanpercentile(np.concatenate([np.abs(r.dominant[r.ok]) for r in results]), 99)),
        "thickness_mm": thickness, "window_px": window, "step_px": step, "geodesic_window_px": 2 * radius + 1,
        "seconds": round(time.perf_counter() - t0, 2), "output": str(out),
    }
    write_json(out / "summary.json", summary)
    return summary


def register(app: typer.Typer) -> None:
    @app.command("strain")
    def strain(
        sequence: Path = typer.Argument(..., help="Folder of points_*.npy, a .npy/.npz (F,H,W,3) or a zarr store."),
        anchors: str = typer.Option(..., "--anchors", help="'u1,v1,u2,v2' pixel anchors (';' between wings) "
                                                           "or 'auto' (dark dots in the texture)."),
        out: Path = typer.Option(..., "--out", "-o", help="Output folder."),
        thickness: float = typer.Option(0.1, help="Membrane thickness h (mm) for E = (h/2)·κ (Eq. 6.11)."),
        window: int = typer.Option(11, help="Quadratic-fit neighbourhood (odd, pixels)."),
        step: int = typer.Option(4, help="Track every STEP-th pixel of the reference frame."),
        wings: int = typer.Option(1, help="Number of wings (anchor pairs) for --anchors auto."),
        radius: int = typer.Option(3, help="Geodesic marching window half-size (3 = the dissertation's 7×7)."),
        reference: int = typer.Option(0, help="Index of the undeformed reference frame."),
        fill_dots: int = typer.Option(8, "--fill-dots", help="Fill unreconstructed anchor-dot holes up to this "
                                                             "radius (px) from the surrounding surface; 0 = off."),
        no_figures: bool = typer.Option(False, "--no-figures", help="Skip the PNG maps and the GIF."),
        json_: bool = typer.Option(False, "--json", help="Print a JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
    ) -> None:
        """Track every point of an inextensible wing by geodesic distances (Eq. 6.9) and map its
        Kirchhoff–Love bending strain (Eq. 6.10–6.21): CSV, VTK, PNG maps, GIF.

        Example: fringe3d strain wing-points/ --anchors 120,80,300,82 -o wing-strain --json
        """
        set_quiet(quiet or json_)
        summary = run_strain(sequence, anchors, out, thickness, window, step, wings, radius, reference,
                             figures=not no_figures, fill_dots=fill_dots)
        if json_:
            print_json(summary)
        elif not quiet:
            console.print(make_table("strain", ["field", "value"], [[k, str(v)] for k, v in summary.items()]))
