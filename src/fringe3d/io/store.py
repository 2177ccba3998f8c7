"""A resumable, chunked, compressed store of point maps for long sequences (zarr).

Layout (a zarr v3 group on disk), one chunk per frame in every per-frame array::

    OUT.zarr/
      depth    (F, H, W) float32 mm, layout "ray_depth": the ray parameter s of X = O + s*D
               (for a pinhole camera the camera-frame depth z); NaN: no point
      ray_origin     (3,) float64 mm, layout "ray_depth": O, the camera centre (world frame)
      ray_direction  (3, H, W) float32, layout "ray_depth": D per pixel (device depth 1)
      points   (F, H, W, 3) float32 mm, layout "xyz": the points themselves; NaN: no point
      quality  (F, H, W) uint8 quality bits (fringe3d.decode.edges; 0 = kept), optional
      sigma_z  (F, H, W) float16 mm predicted standard deviation of z (NaN: none), optional
               (three significant digits are all an uncertainty carries; half the bytes of
               float32; stores written before hold float32, read the same way)
      done     (F,) uint8: 1 once frame k is completely written
      attrs    {"format": "fringe3d-point-store", "version": 2, "layout": "ray_depth" | "xyz",
                "frames", "height", "width", "completed", "meta": {...}}

Whatever the layout, :meth:`PointMapStore.points` gives the ``(H, W, 3)`` float32 point map:
``ray_depth`` evaluates ``O + s*D`` with :func:`fringe3d.optics.rays.ray_points`, the function
the fused reconstruction itself makes its points with, so the points are the ones an ``xyz``
store of the same run holds, bit for bit, in a third of the bytes (one float32 per pixel instead
of three). Reconstructions that do not give ``s`` (least squares, telecentric cameras, the
decode path) use ``xyz``.

A frame is marked done only after its chunks have been written, so an interrupted run resumes
by rewriting exactly the frames not marked done (:meth:`PointMapStore.pending`).

Every array carries zarr v3 ``dimension_names`` (frame, row, column, axis) and the store holds
coordinate arrays: ``frame`` (index), ``row`` / ``column`` (pixel indices), ``axis`` (``"x", "y",
"z"``) and, when the frame rate is known, ``time`` (s, each 3D frame's first captured frame / rate,
a non-index coordinate along ``frame``). Its metadata is consolidated, so a plain
``xarray.open_zarr(path)`` opens the store as a Dataset without a warning; with ``ray_depth``
the points are ``ds.ray_origin + ds.depth * ds.ray_direction`` (``axis`` then the last dimension
after ``transpose``).
"""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from fringe3d.io._chunk_write import chunk_writer
from fringe3d.io._float16 import to_float16
from fringe3d.optics.rays import ray_points
from fringe3d.utils.write_guard import is_being_written

STORE_FORMAT = "fringe3d-point-store"
STORE_VERSION = 2
LAYOUTS = ("xyz", "ray_depth")
#: Blosc codec of the per-frame chunks. In ``benchmarks/bench_sequence.py`` (1280x1024) lz4
#: wrote an xyz point map 3x faster than zstd level 3 (69 vs 210 ms, a loaded 2-core machine)
#: for 16 % more bytes (10.7 vs 9.3 MB); writing is on the critical path of a sequence.
CODEC: Literal["lz4", "zstd", "none"] = "lz4"
#: Blosc compression level of each codec
CODEC_LEVELS = {"lz4": 5, "zstd": 3}
#: byte shuffle per dtype: float data compress only once their bytes are regrouped
SHUFFLE: Literal["shuffle", "noshuffle", "bitshuffle"] = "shuffle"
#: zarr's default compares every chunk written with the fill value to skip empty ones; a 3D
#: frame is never all fill, and the comparison cost more than the compression (depth 23 -> 9 ms,
#: quality 13 -> 2 ms a 1280x1024 frame in ``benchmarks/bench_sequence.py``'s machine)
FRAME_CONFIG: dict[str, Any] = {"write_empty_chunks": True}
#: chunk keys ``c.K.0.0`` (one folder per array): ``/`` would make a folder per frame, and on the
#: development machine creating it cost about 1.5 ms per array and frame (a third of the write)
FRAME_KEYS: dict[str, Any] = {"name": "default", "separator": "."}
#: zarr v3 ``dimension_names`` (what ``xarray.open_zarr`` names the dimensions)
POINT_DIMS = ("frame", "row", "column", "axis")
MAP_DIMS = ("frame", "row", "column")
POINT_ATTRS: dict[str, Any] = {"units": "mm", "long_name": "camera-frame 3D point per pixel (NaN: no point)",
                               "axis_labels": ["x", "y", "z"]}
DEPTH_ATTRS: dict[str, Any] = {"units": "mm", "long_name": "ray parameter s of X = ray_origin + s * ray_direction "
                               "(the camera-frame depth; NaN: no point)"}
ORIGIN_ATTRS: dict[str, Any] = {"units": "mm", "long_name": "camera centre O of the rays (world frame)",
                                "axis_labels": ["x", "y", "z"]}
DIRECTION_ATTRS: dict[str, Any] = {"units": "1", "long_name": "ray direction D per pixel, device depth 1",
                                   "axis_labels": ["x", "y", "z"]}
QUALITY_ATTRS: dict[str, Any] = {"long_name": "quality bits (fringe3d.decode.edges; 0: the point is kept)",
                                 "flag_masks": [1, 2, 4, 8, 16, 32, 64, 128],
                                 "flag_meanings": "invalid edge inconsistent gradient mod_drop rim order saturated"}
SIGMA_ATTRS: dict[str, Any] = {"units": "mm", "long_name": "predicted standard deviation of z (NaN: none)"}
DONE_ATTRS: dict[str, Any] = {"long_name": "1 once the frame is completely written", "flag_values": [0, 1]}


def _write_coordinates(g, frames: int, height: int, width: int, times):
    """Coordinate arrays (frame, row, column, axis, and time in s when given), then the group's
    metadata consolidated (what ``xarray.open_zarr`` looks for first). Returns the consolidated
    group: later attribute writes through it keep the consolidated metadata."""
    import zarr

    coords: dict[str, tuple[np.ndarray, dict]] = {
        "frame": (np.arange(frames, dtype=np.int64), {"long_name": "3D frame index"}),
        "row": (np.arange(height, dtype=np.int32), {"long_name": "camera pixel row", "units": "px"}),
        "column": (np.arange(width, dtype=np.int32), {"long_name": "camera pixel column", "units": "px"})}
    if times is not None:
        t = np.asarray(times, np.float64)
        if t.shape != (frames,):
            raise ValueError(f"times must hold one value per frame ({frames},) in s, got {t.shape}")
        coords["time"] = (t, {"units": "s", "long_name": "capture time of the 3D frame's first frame"})
    for name, (values, attrs) in coords.items():
        a = g.create_array(name, shape=values.shape, dtype=values.dtype, dimension_names=("frame",)
                           if name == "time" else (name,), attributes=attrs)
        a[:] = values
    ax = g.create_array("axis", shape=(3,), dtype=str, dimension_names=("axis",))
    ax[:] = np.array(["x", "y", "z"])
    with warnings.catch_warnings():  # "consolidated metadata is not part of the zarr 3 spec": xarray reads it
        warnings.simplefilter("ignore", UserWarning)
        return zarr.consolidate_metadata(g.store)


#: The codecs a store can be written with (``--store-codec``).
CODECS = ("lz4", "zstd", "none")


def _compressor(codec: str | None = None):
    """The Blosc codec ``codec`` (default :data:`CODEC`; None: chunks stored raw)."""
    from zarr.codecs import BloscCodec
    codec = CODEC if codec is None else codec
    if codec not in CODECS:
        raise ValueError(f"unknown point store codec {codec!r}; expected one of {', '.join(CODECS)}")
    if codec == "none":
        return None
    return BloscCodec(cname=codec, clevel=CODEC_LEVELS[codec], shuffle=SHUFFLE)  # type: ignore[arg-type]  # checked against CODECS


@dataclass(frozen=True)
class StoreSettings:
    """What a new point store holds and how its per-frame chunks are compressed
    (:meth:`PointMapStore.open`).

    Attributes
    ----------
    layout : str
        ``"xyz"`` (the points, (H, W, 3) float32 mm per frame) or ``"ray_depth"`` (the ray
        parameter, (H, W) float32 mm per frame, with the camera rays; :data:`LAYOUTS`).
    quality : bool
        Add the per-frame quality bits (uint8, 0 = kept).
    sigma : bool
        Add the per-frame predicted standard deviation of z, sigma_z (float16 mm).
    codec : str | None
        Compression of the per-frame chunks (:data:`CODECS`); ``None``: :data:`CODEC`. A resumed
        store keeps its own.
    """

    layout: str = "xyz"
    quality: bool = False
    sigma: bool = False
    codec: str | None = None


class PointMapStore:
    """Point maps (and their quality maps and sigma_z) of many frames in one zarr store.

    Use :meth:`open` to create or resume. ``store.write_frame(k, ...)`` stores frame ``k``,
    ``store.mark_done([k])`` marks it complete (``store.write(k, points)`` does both for an
    ``xyz`` store); ``store.pending()`` lists frames still to do; ``store.points(k)`` (alias
    ``read``) gives the point map whatever the layout.
    """

    def __init__(self, group, path: Path):
        self.group = group
        self.path = path
        self.layout: str = str(group.attrs.get("layout", "xyz"))
        self.points_array = group["points"] if self.layout == "xyz" else None
        self.depth_array = group["depth"] if self.layout == "ray_depth" else None
        self.quality_array = group["quality"] if "quality" in group else None
        self.sigma_array = group["sigma_z"] if "sigma_z" in group else None
        self.done_array = group["done"]
        self._done = np.asarray(self.done_array[:], bool)
        self._rays: tuple[np.ndarray, np.ndarray] | None = None
        # per-frame arrays written chunk by chunk without zarr's per-call cost (fringe3d.io._chunk_write)
        self._writers = {id(a): chunk_writer(a) for a in (self.points_array, self.depth_array, self.quality_array,
                                                          self.sigma_array) if a is not None}

    # -- creation / resumption --------------------------------------------------------
    @classmethod
    def open(cls, path: str | os.PathLike, frames: int, height: int, width: int, meta: dict | None = None,
             overwrite: bool = False, settings: StoreSettings | None = None,
             rays: tuple[np.ndarray, np.ndarray] | None = None, times=None) -> "PointMapStore":
        """Create a store for ``frames`` point maps of ``height x width``, or resume an existing one.

        ``settings`` (:class:`StoreSettings`, default ``xyz`` without quality or sigma_z, lz4):
        the layout, whether the per-frame quality and sigma_z arrays are added, and the per-frame
        arrays' compression (a resumed store keeps its own). Layout ``"ray_depth"`` needs
        ``rays = (O (3,), D_planes (3, H, W))`` of the pinhole camera
        (:class:`fringe3d.optics.rays.RayGeometry`); ``times`` (F,) the seconds of each frame
        (the ``time`` coordinate), optional. An existing store
        must hold the same number of frames, image size, layout and arrays (else ValueError, so a
        resumed run never mixes two different sequences).
        """
        import zarr  # optional heavy dependency: loaded only when a store is opened

        settings = settings or StoreSettings()
        layout, quality, sigma, codec = settings.layout, settings.quality, settings.sigma, settings.codec

        if frames <= 0 or height <= 0 or width <= 0:
            raise ValueError(f"a point store needs positive frames, height and width, got {frames}, {height}, {width}")
        if layout not in LAYOUTS:
            raise ValueError(f"unknown point store layout {layout!r}; expected one of {', '.join(LAYOUTS)}")
        if layout == "ray_depth":
            if rays is None:
                raise ValueError("a ray_depth point store needs the camera rays (O, D_planes)")
            O, D = np.asarray(rays[0], np.float64), np.asarray(rays[1], np.float32)
            if O.shape != (3,) or D.shape != (3, height, width):
                raise ValueError(f"ray origin {O.shape} / directions {D.shape} must be (3,) / (3, {height}, {width})")
        path = Path(path)
        if path.exists() and not overwrite:
            try:
                g = zarr.open_group(str(path), mode="r+")
                attrs = dict(g.attrs)
            except Exception as e:
                raise ValueError(f"{path} exists but is not a fringe3d point store ({e}); choose another output "
                                 "or remove it") from None
            unfinished = "format" not in attrs and is_being_written(path)  # its creation was cut short
            if attrs.get("format") != STORE_FORMAT and not unfinished:
                raise ValueError(f"{path} exists but is not a fringe3d point store (format {attrs.get('format')!r})")
            if unfinished:  # an interrupted run of this output started the store but recorded no frame in it
                return cls.open(path, frames, height, width, meta, overwrite=True, settings=settings, rays=rays,
                                times=times)
            got = (attrs.get("frames"), attrs.get("height"), attrs.get("width"))
            if got != (frames, height, width):
                raise ValueError(f"{path} holds {got[0]} frames of {got[2]}x{got[1]}, "
                                 f"but this run makes {frames} frames "
                                 f"of {width}x{height}; use a new output folder to start over")
            have = (attrs.get("layout", "xyz"), "quality" in g, "sigma_z" in g)
            if have != (layout, quality, sigma):
                raise ValueError(f"{path} has layout {have[0]!r} (quality map: {have[1]}, sigma_z: {have[2]}) but this "
                                 f"run writes {layout!r} (quality map: {quality}, sigma_z: {sigma}); use a new "
                                 "output folder to start over")
            return cls(g, path)
        g = zarr.open_group(str(path), mode="w")
        comp = _compressor(codec)

        def per_frame(name, tail, dtype, fill, dims, attrs):
            """One chunk per frame, compressed, no fill-value check on write, flat chunk keys."""
            if times is not None:
                attrs = {**attrs, "coordinates": "time"}  # CF: xarray reads ``time`` as this array's coordinate
            g.create_array(name, shape=(frames,) + tail, chunks=(1,) + tail, dtype=dtype, fill_value=fill,
                           dimension_names=dims, compressors=comp, config=FRAME_CONFIG, chunk_key_encoding=FRAME_KEYS,
                           attributes=attrs)

        if layout == "xyz":
            per_frame("points", (height, width, 3), "float32", np.nan, POINT_DIMS, POINT_ATTRS)
        else:
            per_frame("depth", (height, width), "float32", np.nan, MAP_DIMS, DEPTH_ATTRS)
            o = g.create_array("ray_origin", shape=(3,), dtype="float64", dimension_names=POINT_DIMS[3:],
                               attributes=ORIGIN_ATTRS)
            o[:] = O
            d = g.create_array("ray_direction", shape=(3, height, width), chunks=(3, height, width),
                               dtype="float32", dimension_names=("axis",) + MAP_DIMS[1:], compressors=comp,
                               attributes=DIRECTION_ATTRS)
            d[:] = D
        if quality:
            per_frame("quality", (height, width), "uint8", 1, MAP_DIMS, QUALITY_ATTRS)
        if sigma:
            per_frame("sigma_z", (height, width), "float16", np.nan, MAP_DIMS, SIGMA_ATTRS)
        g.create_array("done", shape=(frames,), chunks=(min(frames, 65536),), dtype="uint8", fill_value=0,
                       dimension_names=POINT_DIMS[:1], attributes=DONE_ATTRS)
        g.update_attributes({"format": STORE_FORMAT, "version": STORE_VERSION, "layout": layout, "frames": frames,
                               "height": height, "width": width, "completed": 0, "meta": meta or {}})
        return cls(_write_coordinates(g, frames, height, width, times), path)

    @classmethod
    def open_existing(cls, path: str | os.PathLike) -> "PointMapStore":
        """Open a store for reading (FileNotFoundError / ValueError when it is not one)."""
        import zarr  # optional heavy dependency: loaded only when a store is opened
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"no point store at {path}")
        g = zarr.open_group(str(path), mode="r+")
        if g.attrs.get("format") != STORE_FORMAT:
            raise ValueError(f"{path} is not a fringe3d point store")
        if g.attrs.get("layout", "xyz") not in LAYOUTS:
            raise ValueError(f"{path}: unknown point store layout {g.attrs.get('layout')!r}; expected one of "
                             f"{', '.join(LAYOUTS)} (written by a newer fringe3d?)")
        return cls(g, path)

    # -- progress ------------------------------------------------------------------------
    @property
    def frames(self) -> int:
        return int(self.done_array.shape[0])

    @property
    def shape(self) -> tuple[int, int]:
        return int(self.group.attrs["height"]), int(self.group.attrs["width"])

    @property
    def meta(self) -> dict:
        return dict(self.group.attrs.get("meta", {}))

    @property
    def has_quality(self) -> bool:
        return self.quality_array is not None

    @property
    def has_sigma(self) -> bool:
        return self.sigma_array is not None

    def is_done(self, k: int) -> bool:
        return bool(self._done[k])

    def pending(self) -> list[int]:
        """Frame indices not yet completely written."""
        return [int(k) for k in np.flatnonzero(~self._done)]

    @property
    def completed(self) -> int:
        return int(self._done.sum())

    # -- writing ---------------------------------------------------------------------------
    def write(self, k: int, points: np.ndarray) -> None:
        """Store frame ``k`` of an ``xyz`` store (``(H, W, 3)`` float32 mm) and then mark it complete."""
        self.write_points(k, points)
        self.mark_done([k])

    def write_points(self, k: int, points: np.ndarray) -> None:
        """Store frame ``k``'s point map of an ``xyz`` store without marking it done."""
        self.write_frame(k, points=points)

    def write_frame(self, k: int, points: np.ndarray | None = None, depth: np.ndarray | None = None,
                    quality: np.ndarray | None = None, sigma_z: np.ndarray | None = None) -> None:
        """Store frame ``k``'s chunks without marking it done (a worker's write; the client marks
        it with :meth:`mark_done` once the task has returned).

        ``points`` (H, W, 3) float32 mm for an ``xyz`` store, ``depth`` (H, W) float32 ray
        parameters for a ``ray_depth`` one; ``quality`` (H, W) uint8 and ``sigma_z`` (H, W) mm
        where the store holds them (all of the store's arrays must be given).
        """
        if not 0 <= k < self.frames:
            raise ValueError(f"frame index {k} outside the store's 0..{self.frames - 1}")
        H, W = self.shape
        if self.layout == "xyz":
            if points is None:
                raise ValueError(f"frame {k}: an xyz point store needs the point map")
            P = np.asarray(points, np.float32)
            if P.shape != (H, W, 3):
                raise ValueError(f"point map of frame {k} has shape {P.shape}, the store holds {(H, W, 3)}")
            data = [(self.points_array, P)]
        else:
            if depth is None:
                raise ValueError(f"frame {k}: a ray_depth point store needs the ray parameters (depth)")
            data = [(self.depth_array, self._check(k, "depth", depth, np.float32))]
        for arr, name, v, dt in ((self.quality_array, "quality", quality, np.uint8),
                                 (self.sigma_array, "sigma_z", sigma_z,
                                  None if self.sigma_array is None else self.sigma_array.dtype)):
            if arr is not None:
                if v is None:
                    raise ValueError(f"frame {k}: the store holds {name} but none was given")
                data.append((arr, self._check(k, name, v, dt)))
        for arr, v in data:
            write = self._writers.get(id(arr))
            if write is not None:
                write(k, v)
            else:
                arr[k] = v  # type: ignore[index]  # the arrays of this layout (never None here)

    def _check(self, k: int, name: str, v: np.ndarray, dtype) -> np.ndarray:
        v = np.asarray(v)
        if v.shape != self.shape:
            raise ValueError(f"{name} of frame {k} has shape {v.shape}, the store holds {self.shape}")
        if v.dtype == np.float32 and dtype == np.float16:  # sigma_z: numpy's cast in one vectorised pass
            return to_float16(v)
        return v.astype(dtype, copy=False)

    def mark_done(self, ks) -> None:
        """Mark frames ``ks`` complete (their chunks are written): one write of the ``done``
        array (its changed span) and of the ``completed`` attribute however many frames."""
        ks = np.asarray(list(ks), np.int64)
        if not ks.size:
            return
        self._done[ks] = True
        lo, hi = int(ks.min()), int(ks.max()) + 1
        self.done_array[lo:hi] = self._done[lo:hi].astype(np.uint8)
        self.group.attrs["completed"] = self.completed

    # -- reading ---------------------------------------------------------------------------
    @property
    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(O (3,) float64, D_planes (3, H, W) float32)`` of a ``ray_depth`` store."""
        if self.layout != "ray_depth":
            raise ValueError(f"{self.path} stores xyz points, not camera rays")
        if self._rays is None:
            self._rays = (np.asarray(self.group["ray_origin"][:], np.float64),
                          np.ascontiguousarray(self.group["ray_direction"][:], np.float32))
        return self._rays

    def points(self, k: int) -> np.ndarray:
        """Point map of frame ``k`` (``(H, W, 3)`` float32 mm; all NaN if never written)."""
        if self.points_array is not None:
            return np.asarray(self.points_array[k])
        return ray_points(*self.rays, self.depth(k))

    read = points

    def depth(self, k: int) -> np.ndarray:
        """(H, W) float32 ray parameters of frame ``k`` (``ray_depth``) or the points' z (``xyz``)."""
        if self.depth_array is not None:
            return np.asarray(self.depth_array[k])
        assert self.points_array is not None  # an xyz store
        return np.asarray(self.points_array[k, ..., 2])

    def quality(self, k: int) -> np.ndarray:
        """(H, W) uint8 quality bits of frame ``k`` (ValueError when the store holds none)."""
        if self.quality_array is None:
            raise ValueError(f"{self.path} holds no quality maps (reconstructed with `store_quality=False`)")
        return np.asarray(self.quality_array[k])

    def sigma_z(self, k: int) -> np.ndarray:
        """(H, W) float32 sigma_z (mm) of frame ``k`` (ValueError when the store holds none)."""
        if self.sigma_array is None:
            raise ValueError(f"{self.path} holds no sigma_z maps (reconstructed with `store_quality=False`)")
        return np.asarray(self.sigma_array[k], np.float32)
