"""Ground truth of a rendered capture, per camera pixel (and per frame for moving scenes).

Saved as ``truth/truth.npz`` (arrays) + ``truth/truth.json`` (metadata: shapes, units,
per-direction fringe angle and period, frame times, whether the scene moves).
"""
from __future__ import annotations

import zipfile
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fringe3d.optics import Rig
from fringe3d.patterns.conventions import fringe_coordinate, w_to_phase
from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.jsonfile import read_json, write_json
from fringe3d.io.arrays import load_array
from fringe3d.io.npy_stream import NpyFrameWriter, pack_npz

TRUTH_FORMAT = "fringe3d-truth"
ARRAY_FIELDS = ("xyz", "depth", "up", "vp", "normal", "object_id", "mask", "hit", "material_uv")


@dataclass(eq=False)
class Truth:
    """Per-pixel ground truth.

    Shapes are ``(H, W, ...)`` for a static scene, ``(F, H, W, ...)`` for a moving one
    (``per_frame=True``; index ``F`` follows the capture's frames).

    Attributes
    ----------
    xyz : float64 (..., H, W, 3)
        Surface point, mm, world frame (= camera frame for pinhole rigs, projector frame for
        telecentric rigs); NaN where no surface.
    depth : float64 (..., H, W)
        Camera-frame z (pinhole, mm) or distance along the telecentric viewing direction.
    up, vp : float64 (..., H, W)
        Projector column / row (pixels) of the surface point, Eq. (2.8) through the projector.
    phase : dict[str, float32 (..., H, W)]
        Absolute phase per fringe direction, ``Phi = 2 pi w / T`` with
        ``w = vp cos(alpha) + up sin(alpha)`` and ``T`` that direction's narrowest period.
    normal : float32 (..., H, W, 3)
        Unit surface normal (facing the camera).
    object_id : int32 (..., H, W)
        Scene object index, -1 where no hit.
    mask : bool (..., H, W)
        Valid: hit, inside the projector image, facing and lit by the projector (not shadowed).
    hit : bool (..., H, W)
        The camera ray hit a surface.
    material_uv : float32 (..., H, W, 2) or None
        Scene material coordinates (e.g. the wing's flat-sheet coordinates, mm).
    extras : dict[str, ndarray]
        Scene-specific fields (e.g. analytic curvature), same leading shape.
    meta : dict
        ``angles``, ``periods`` (per direction), ``times`` (s), ``per_frame``, ``rig`` kind...
    """

    xyz: np.ndarray
    depth: np.ndarray
    up: np.ndarray
    vp: np.ndarray
    phase: dict
    normal: np.ndarray
    object_id: np.ndarray
    mask: np.ndarray
    hit: np.ndarray
    material_uv: np.ndarray | None = None
    extras: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    @property
    def per_frame(self) -> bool:
        return bool(self.meta.get("per_frame", False))

    def frame(self, k: int) -> Truth:
        """The truth at frame ``k`` (the same object for a static scene)."""
        if not self.per_frame:
            return self
        def pick(a):
            return None if a is None else a[k]
        return Truth(xyz=self.xyz[k], depth=self.depth[k], up=self.up[k], vp=self.vp[k],
                     phase={d: p[k] for d, p in self.phase.items()}, normal=self.normal[k],
                     object_id=self.object_id[k], mask=self.mask[k], hit=self.hit[k],
                     material_uv=pick(self.material_uv), extras={n: a[k] for n, a in self.extras.items()},
                     meta={**self.meta, "per_frame": False, "frame": k})

    # -- files ------------------------------------------------------------------------
    def save(self, folder) -> Path:
        """Write ``folder/truth.npz`` and ``folder/truth.json`` atomically; returns the folder."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        arrays = {n: getattr(self, n) for n in ARRAY_FIELDS if getattr(self, n) is not None}
        arrays.update({f"phase_{d}": p for d, p in self.phase.items()})
        arrays.update({f"extra_{n}": a for n, a in self.extras.items()})
        with atomic_path(folder / "truth.npz") as tmp:
            write_npz(tmp, arrays)
        meta = truth_json(self.meta, list(self.phase), list(self.extras), self.depth.shape)
        write_json(folder / "truth.json", meta, units={**meta["units"], "times": "s"})
        return folder

    @classmethod
    def load(cls, folder) -> Truth:
        """Read a truth bundle written by :meth:`save` (``folder`` may be a capture folder)."""
        folder = Path(folder)
        if (folder / "truth").is_dir():
            folder = folder / "truth"
        npz, js = folder / "truth.npz", folder / "truth.json"
        for p in (npz, js):
            if not p.exists():
                raise FileNotFoundError(f"no ground-truth file {p} (expected truth.npz and truth.json)")
        meta = read_json(js, "ground-truth metadata")
        try:
            with load_array(npz, "ground-truth file") as z:
                data = {k: z[k] for k in z.files}
        except (ValueError, OSError, EOFError, zipfile.BadZipFile) as e:
            raise ValueError(f"ground-truth file {npz} is damaged ({e}); simulate the capture again") from None
        if not isinstance(meta.get("directions", []), list) or not isinstance(meta.get("extras", []), list):
            raise ValueError(f"{js}: fields directions and extras must be lists of labels")
        missing = [n for n in ARRAY_FIELDS if n != "material_uv" and n not in data]
        if missing:
            raise ValueError(f"{npz}: missing array(s) {missing}")
        try:
            phase = {d: data[f"phase_{d}"] for d in meta.get("directions", [])}
            extras = {n: data[f"extra_{n}"] for n in meta.get("extras", [])}
        except (KeyError, TypeError) as e:
            raise ValueError(f"{npz}: no array for {e} named in {js}") from None
        for k in ("format", "version", "directions", "extras", "shape", "units", "provenance"):
            meta.pop(k, None)
        return cls(xyz=data["xyz"], depth=data["depth"], up=data["up"], vp=data["vp"], phase=phase,
                   normal=data["normal"], object_id=data["object_id"], mask=data["mask"], hit=data["hit"],
                   material_uv=data.get("material_uv"), extras=extras, meta=meta)


def truth_json(meta: dict, directions: list[str], extras: list[str], shape) -> dict:
    """The content of ``truth.json``: ``meta`` plus the format, the directions and extras held, the
    depth map's shape and the units."""
    return {"format": TRUTH_FORMAT, "version": 1, **meta, "directions": list(directions), "extras": list(extras),
            "shape": [int(x) for x in shape],
            "units": {"xyz": "mm", "depth": "mm", "up": "projector px", "vp": "projector px", "phase": "rad"}}


def write_npz(path, arrays: dict, level: int = 1) -> None:
    """``np.savez_compressed`` with a fast deflate level (truth maps are large and smooth)."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=level) as zf:
        for name, arr in arrays.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.asanyarray(arr), allow_pickle=False)


def direction_phase(up: np.ndarray, vp: np.ndarray, angle: float, period: float) -> np.ndarray:
    """Absolute phase of a fringe direction, ``Phi = 2 pi (vp cos a + up sin a) / T`` (Eq. 2.1-2.2)."""
    return w_to_phase(fringe_coordinate(up, vp, angle), period, scale_first=True)


def directions_of(patterns) -> dict[str, tuple[float, float]]:
    """``{direction: (angle, narrowest period)}`` over the phase frames of a pattern set."""
    out: dict[str, tuple[float, float]] = {}
    for f in patterns.frames:
        if f.role != "phase" or not f.direction:
            continue
        if f.direction not in out or f.period < out[f.direction][1]:
            out[f.direction] = (f.angle, f.period)
    return out


# -- assembly from the renderer's per-frame geometry ------------------------------------
def frame_truth(geo, shape, dirs_info) -> dict:
    """One instant's per-pixel truth as compact (H, W, ...) arrays from the renderer's flat
    ``Geometry`` (N = H*W rows): points, depth, up, vp, normal, object_id, lit, hit,
    material_uv, extras; ``dirs_info`` = :func:`directions_of`."""
    H, W = shape

    def grid(a, dtype, trail=()):
        return np.asarray(a).reshape((H, W) + trail).astype(dtype)

    out = {"xyz": grid(geo.points, np.float64, (3,)),  # float64: reprojects to pixel centres < 1e-6 px
           "depth": grid(geo.depth, np.float64), "up": grid(geo.up, np.float64), "vp": grid(geo.vp, np.float64),
           "normal": grid(geo.normal, np.float32, (3,)), "object_id": grid(geo.object_id, np.int32),
           "mask": grid(geo.lit, bool), "hit": grid(geo.hit, bool),
           "material_uv": None if geo.material_uv is None else grid(geo.material_uv, np.float32, (2,)),
           "phase": {d: grid(direction_phase(geo.up, geo.vp, a, p), np.float32) for d, (a, p) in dirs_info.items()},
           "extras": {n: np.asarray(v).reshape((H, W) + np.shape(v)[1:]) for n, v in geo.extras.items()}}
    return out


class TruthFrames:
    """Per-frame truth of F instants, filled frame by frame into preallocated (F, H, W, ...)
    arrays (no per-frame copies kept, no final stacking)."""

    def __init__(self, n_frames: int):
        self.n = n_frames
        self.data: dict | None = None

    def put(self, k: int, ft: dict) -> None:
        flat = _flatten(ft)
        if self.data is None:
            self.data = {key: None if v is None else np.empty((self.n,) + v.shape, v.dtype) for key, v in flat.items()}
        for key, arr in self.data.items():
            if arr is None:
                continue
            v = flat.get(key)
            if v is None:  # a field this frame lacks
                arr[k] = np.nan if arr.dtype.kind == "f" else 0
            else:
                arr[k] = v


class TruthWriter:
    """Per-frame truth of a moving scene written to ``folder`` frame by frame, in the layout
    :meth:`Truth.save` writes (``truth.npz`` with ``(F, H, W, ...)`` arrays + ``truth.json``), so
    :meth:`Truth.load` reads it back unchanged; memory holds one frame whatever F is.

    Use as a context manager: :meth:`put` frames ``0 .. F - 1`` in order (a field a later frame
    lacks is written NaN / 0, as :class:`TruthFrames` does), then :meth:`finish`. Each field goes to
    a temporary ``.npy`` (:class:`~fringe3d.io.npy_stream.NpyFrameWriter`) packed into
    ``truth.npz`` at the end; leaving the block early removes them.
    """

    def __init__(self, folder, n_frames: int):
        self.folder, self.n = Path(folder), int(n_frames)
        self._stack = ExitStack()
        self._writers: dict = {}
        self.count = 0
        self.mask_sum = 0

    def __enter__(self) -> "TruthWriter":
        self.folder.mkdir(parents=True, exist_ok=True)
        return self

    def __exit__(self, *exc) -> bool:
        try:
            return bool(self._stack.__exit__(*exc))
        finally:
            for w in self._writers.values():
                if w is not None:
                    w.path.unlink(missing_ok=True)

    def put(self, k: int, ft: dict) -> None:
        """Write frame ``k`` (the next one) from a :func:`frame_truth` dict."""
        if k != self.count:
            raise ValueError(f"truth frames must come in order: got frame {k}, expected {self.count}")
        flat = _flatten(ft)
        if not self._writers:
            for key, v in flat.items():
                self._writers[key] = None if v is None else self._stack.enter_context(NpyFrameWriter(
                    self.folder / f".{_member(key)}.stream.npy", self.n, v.shape, v.dtype))
        for key, w in self._writers.items():
            if w is None:
                continue
            v = flat.get(key)
            w.append(v if v is not None else np.full(w.frame_shape, np.nan if w.dtype.kind == "f" else 0, w.dtype))
        self.mask_sum += int(np.count_nonzero(flat["mask"]))
        self.count += 1

    def finish(self, meta: dict) -> Path:
        """Close the fields, pack ``truth.npz``, write ``truth.json`` (``meta`` as :func:`make_truth`
        and the renderer make it); returns the folder."""
        if self.count != self.n:
            raise ValueError(f"{self.count} of {self.n} truth frames written")
        writers = {k: w for k, w in self._writers.items() if w is not None}
        self._stack.close()   # every field's .npy is now complete and in place
        pack_npz(self.folder / "truth.npz", {_member(k): w.path for k, w in writers.items()})
        dirs = [k[1] for k in writers if isinstance(k, tuple) and k[0] == "phase"]
        extras = [k[1] for k in writers if isinstance(k, tuple) and k[0] == "extras"]
        content = truth_json(meta, dirs, extras, (self.n,) + writers["depth"].frame_shape)
        write_json(self.folder / "truth.json", content, units={**content["units"], "times": "s"})  # as Truth.save
        return self.folder


def _member(key) -> str:
    """Name of a :func:`_flatten` key in ``truth.npz`` (``phase_DIR``, ``extra_NAME``, else the field)."""
    if isinstance(key, tuple):
        return f"phase_{key[1]}" if key[0] == "phase" else f"extra_{key[1]}"
    return key


def truth_meta(dirs_info: dict[str, tuple[float, float]], times, static: bool, rig: Rig) -> dict:
    """The metadata :func:`make_truth` gives a :class:`Truth`."""
    return {"per_frame": not static, "times": [float(t) for t in times],
            "fringe": {d: {"angle": a, "period": p} for d, (a, p) in dirs_info.items()},
            "camera": rig.camera.kind, "frame": "camera" if rig.camera.kind == "pinhole" else "projector"}


def _flatten(ft: dict) -> dict:
    out = {k: v for k, v in ft.items() if k not in ("phase", "extras")}
    out.update({("phase", d): v for d, v in ft["phase"].items()})
    out.update({("extras", n): v for n, v in ft["extras"].items()})
    return out


def make_truth(frames: dict | TruthFrames, dirs_info: dict[str, tuple[float, float]], times, static: bool,
               rig: Rig) -> Truth:
    """Assemble :class:`Truth` from one :func:`frame_truth` dict (static scene) or the filled
    :class:`TruthFrames` of a moving scene."""
    data = frames.data if isinstance(frames, TruthFrames) else _flatten(frames)
    assert data is not None, "no frame was put into the TruthFrames"
    names = ("xyz", "depth", "up", "vp", "normal", "object_id", "mask", "hit")
    meta = truth_meta(dirs_info, times, static, rig)
    return Truth(**{n: data[n] for n in names}, material_uv=data.get("material_uv"),
                 phase={k[1]: v for k, v in data.items() if isinstance(k, tuple) and k[0] == "phase"},
                 extras={k[1]: v for k, v in data.items() if isinstance(k, tuple) and k[0] == "extras"},
                 meta=meta)
