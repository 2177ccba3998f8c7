"""Reading a sequence of organized point maps (the input of ``fringe3d strain``, ch. 6).

A sequence is one of

* a folder of per-frame point maps ``points_00000.npy`` … ((H, W, 3) float, mm, NaN invalid),
  optionally with textures ``texture_00000.npy`` / ``.png`` (for automatic anchors);
* a single ``.npy`` / ``.npz`` holding ``points`` (F, H, W, 3) (and optionally ``texture``);
* a zarr store (folder) with arrays ``points`` (F, H, W, 3) and optionally ``texture`` (F, H, W)
  and ``done`` (F,) completion flags, or a :class:`fringe3d.io.store.PointMapStore` of either
  layout (``xyz`` or ``ray_depth``), or a folder holding such a ``points.zarr``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from fringe3d.io.arrays import load_array
from fringe3d.io.images import read_image
from fringe3d.io.store import STORE_FORMAT, PointMapStore

#: Fewest frames a strain sequence may have (a reference frame and a deformed one).
MIN_FRAMES = 2


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
            raise ValueError(f"{self.source} holds no texture images; pass `anchors` u1,v1,u2,v2")
        return np.asarray(self._tex[i](), dtype=np.float64)


def check_point_map_shape(shape, what: str) -> None:
    """ValueError unless ``shape`` is that of an organized point map (H, W, 3)."""
    if len(shape) != 3 or shape[2] != 3:
        raise ValueError(f"{what} has shape {tuple(shape)}; expected an organized point map (H, W, 3) in mm")


def _from_point_store(p: Path, group) -> PointSequence:
    """A ``fringe3d reconstruct`` store, read through :class:`~fringe3d.io.store.PointMapStore` (its
    own reader: xyz per frame, whatever the store's internal layout)."""
    st = PointMapStore.open_existing(p)
    missing = st.pending()
    if missing:
        raise ValueError(f"zarr store {p} is incomplete: frame(s) {missing[:10]} were never "
                         "written; finish (resume) the reconstruction first")
    loaders = [lambda i=i: st.read(i) for i in range(st.frames)]
    tex_arr = group["texture"] if "texture" in group else None
    tex = None if tex_arr is None else [lambda i=i: tex_arr[i] for i in range(tex_arr.shape[0])]
    return _checked(PointSequence(loaders, tex, tuple(st.shape) + (3,), str(p)), p)


def _checked(seq: PointSequence, p: Path) -> PointSequence:
    """``seq`` after the checks every sequence passes (frame count, one texture per frame)."""
    if len(seq) < MIN_FRAMES:
        raise ValueError(f"sequence {p} has {len(seq)} frame(s); expected at least {MIN_FRAMES} "
                         "(a reference frame and a deformed one)")
    if seq._tex is not None and len(seq._tex) != len(seq):
        raise ValueError(f"{p} has {len(seq._tex)} textures for {len(seq)} point maps; expected one per frame")
    return seq


def read_point_sequence(path: str | Path) -> PointSequence:
    """Open a sequence (see the module docstring). Checks that every frame exists, has the same
    (H, W, 3) shape, and that there are at least two frames; raises ``FileNotFoundError`` /
    ``ValueError`` saying what was expected."""
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"sequence {p} does not exist; expected a folder of points_*.npy, a .npy/.npz "
                                "with 'points' (F, H, W, 3), or a zarr store")
    tex = None
    if p.is_dir() and (p / "points.zarr").is_dir() and not list(p.glob("points_*.npy")):
        p = p / "points.zarr"   # the output folder of ``fringe3d reconstruct`` sequences
    arr: Any  # an (F, H, W, 3) array-like: ndarray, memmap, npz member or zarr array
    tex_arr: Any
    if p.is_file():
        if p.suffix == ".npz":
            z = load_array(p, "point sequence")
            if "points" not in z:
                raise ValueError(f"{p} has no 'points' array; found {sorted(z.files)}")
            arr = z["points"]
            tex_arr = z["texture"] if "texture" in z else None
        elif p.suffix == ".npy":
            arr, tex_arr = load_array(p, "point sequence", mmap_mode="r"), None
        else:
            raise ValueError(f"unsupported sequence file {p.name}; expected .npy, .npz or a folder")
        if arr.ndim != 4:
            raise ValueError(f"{p} holds shape {arr.shape}; expected (frames, H, W, 3)")
        loaders = [lambda i=i: arr[i] for i in range(arr.shape[0])]
        if tex_arr is not None:
            tex = [lambda i=i: tex_arr[i] for i in range(tex_arr.shape[0])]
        shape = tuple(arr.shape[1:])
    elif (p / ".zgroup").exists() or (p / "zarr.json").exists() or (p / ".zarray").exists():
        import zarr  # heavy (~1 s to import): only zarr stores need it
        store = zarr.open(str(p), mode="r")
        if not hasattr(store, "shape") and store.attrs.get("format") == STORE_FORMAT:
            return _from_point_store(p, store)
        if hasattr(store, "shape"):
            arr, tex_arr = store, None
        else:
            if "points" not in store:
                raise ValueError(f"zarr store {p} has no 'points' array; found {sorted(store.keys())}")
            arr = store["points"]
            tex_arr = store["texture"] if "texture" in store else None
            if "done" in store:
                missing = np.flatnonzero(np.asarray(store["done"]) == 0)
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
        shapes = [load_array(f, "point map", mmap_mode="r").shape for f in files]
        check_point_map_shape(shapes[0], files[0].name)
        for f, s in zip(files, shapes):
            if s != shapes[0]:
                raise ValueError(f"frames differ in size: {f.name} is {s}, {files[0].name} is {shapes[0]}; "
                                 "expected every frame from the same camera")
        loaders = [lambda f=f: load_array(f, "point map") for f in files]
        shape = tuple(shapes[0])
        tfiles = [f.with_name(f.name.replace("points_", "texture_")) for f in files]
        tpng = [t.with_suffix(".png") for t in tfiles]
        if all(t.exists() for t in tfiles):
            tex = [lambda t=t: load_array(t, "texture map") for t in tfiles]
        elif all(t.exists() for t in tpng):
            tex = [lambda t=t: read_image(t) for t in tpng]
    check_point_map_shape(shape, str(p))
    return _checked(PointSequence(loaders, tex, shape, str(p)), p)


# --- anchors --------------------------------------------------------------------------------------
