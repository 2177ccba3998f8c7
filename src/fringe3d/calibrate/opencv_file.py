"""Import a camera-projector calibration made elsewhere, from an OpenCV ``FileStorage`` YAML/XML.

Node names (first one present wins; ``names`` overrides any of them with one exact node name):

=============  ===================================================================
key            nodes looked for
=============  ===================================================================
``cam_int``    ``cam_int``, ``camera_K``, ``K1``, ``M1``, ``camera_matrix``, ``K``
``cam_dist``   ``cam_dist``, ``camera_dist``, ``D1``, ``distortion_coefficients``, ``dist``
``proj_int``   ``proj_int``, ``projector_K``, ``K2``, ``M2``, ``projector_matrix``
``proj_dist``  ``proj_dist``, ``projector_dist``, ``D2``, ``projector_distortion_coefficients``
``R``          ``R``, ``rotation``
``T``          ``T``, ``translation``
``cam_size``   ``cam_size``, ``camera_size``, ``image_size`` (``[w, h]``), ``img_shape``,
               ``image_shape`` (``[rows, cols]``), else ``image_width`` + ``image_height``
``proj_size``  ``proj_size``, ``projector_size`` (``[w, h]``), ``proj_shape`` (``[rows, cols]``),
               else ``projector_width`` + ``projector_height``
=============  ===================================================================

Several files may be given: OpenCV's ``stereo_calib`` sample writes ``intrinsics.yml`` (``M1 D1
M2 D2``) and ``extrinsics.yml`` (``R T R1 R2 P1 P2 Q``); each node is looked for in the files in
turn (a folder holding ``intrinsics.yml`` and ``extrinsics.yml`` reads both). ``names`` may map
``cam_dist`` or ``proj_dist`` to ``"none"``: a device without lens distortion (zero coefficients).

A size node's order is checked against the intrinsic matrix's principal point ``(cx, cy)``:
the reading that puts it near the image centre (normalised offset within
:data:`CENTRE_TOLERANCE`, better than the other by :data:`ORDER_MARGIN`) wins; a ``[w, h]``
node read as ``[rows, cols]`` (or the reverse) is swapped with a
:class:`~fringe3d.utils.warning_types.CalibrationWarning`, and a size whose order neither its
name nor the principal point decides is refused (pass ``camera_size`` / ``projector_size``)
— never a silently transposed camera.

``R``, ``T`` follow ``cv2.stereoCalibrate``: they map a point from the camera's frame (the first
camera) to the projector's, ``X_p = R X_c + T``, which is fringe3d's pinhole-rig convention
(world frame = camera frame, projector ``[R | t]``, Eq. 2.35-2.38), so they are used unchanged.
``T`` is read in ``unit`` (default ``"mm"``; ``"m"`` multiplies by 1000): fringe3d works in mm.
A ``R`` given as a 3-vector is a Rodrigues rotation vector.

Distortion vectors may have OpenCV's 4, 5, 8, 12 or 14 coefficients (``k1 k2 p1 p2 [k3 [k4 k5 k6
[s1 s2 s3 s4 [tau_x tau_y]]]]``): the rational, thin-prism and tilted terms are modelled as
``cv2.projectPoints`` does (:mod:`fringe3d.optics.distortion`) and kept in the rig; any other
length is refused, naming the node and the file.
"""
from __future__ import annotations

import warnings
from pathlib import Path
from typing import Sequence

import cv2
import numpy as np

from fringe3d.optics import PinholeDevice, Rig
from fringe3d.optics.distortion import COEFFICIENT_NAMES, OPENCV_LENGTHS
from fringe3d.utils.warning_types import CalibrationWarning

NODE_CANDIDATES: dict[str, tuple[str, ...]] = {
    "cam_int": ("cam_int", "camera_K", "K1", "M1", "camera_matrix", "K"),
    "cam_dist": ("cam_dist", "camera_dist", "D1", "distortion_coefficients", "dist"),
    "proj_int": ("proj_int", "projector_K", "K2", "M2", "projector_matrix"),
    "proj_dist": ("proj_dist", "projector_dist", "D2", "projector_distortion_coefficients"),
    "R": ("R", "rotation"),
    "T": ("T", "translation"),
    "cam_size": ("cam_size", "camera_size", "image_size", "img_shape", "image_shape"),
    "proj_size": ("proj_size", "projector_size", "proj_shape"),
}
#: Size nodes holding ``[rows, cols]`` (a numpy shape); the other known size nodes hold ``[w, h]``.
SHAPE_NODES = ("img_shape", "image_shape", "proj_shape")
#: A reading of a size node is plausible when the principal point lies inside the image within
#: this normalised offset of its centre (``max(|cx - (w-1)/2| / w, |cy - (h-1)/2| / h)``) ...
CENTRE_TOLERANCE = 0.25
#: ... and it decides the order when it is closer than the other reading by this much (a 4:3
#: sensor's centred principal point is 0.167 off in the transposed reading).
ORDER_MARGIN = 0.1
NO_DISTORTION = "none"
DIST_KEYS = ("cam_dist", "proj_dist")
_SIZE_PAIRS = {"cam_size": ("image_width", "image_height"), "proj_size": ("projector_width", "projector_height")}
UNITS = {"mm": 1.0, "m": 1000.0}


def parse_node_map(items) -> dict[str, str]:
    """``["cam_int=K1", "T=trans"]`` -> ``{"cam_int": "K1", "T": "trans"}`` (ValueError on a bad item)."""
    out: dict[str, str] = {}
    for item in items or ():
        key, sep, node = str(item).partition("=")
        if not sep or not node or key not in NODE_CANDIDATES:
            raise ValueError(f"`node` {item!r}: expected KEY=NODE with KEY one of {', '.join(NODE_CANDIDATES)}")
        if node == NO_DISTORTION and key not in DIST_KEYS:
            raise ValueError(f"`node` {item!r}: only {' and '.join(DIST_KEYS)} may be '{NO_DISTORTION}' "
                             "(no lens distortion)")
        out[key] = node
    return out


def parse_size(text: str | None, option: str) -> tuple[int, int] | None:
    """``"1280x800"`` -> ``(1280, 800)``; None stays None."""
    if text is None:
        return None
    w, sep, h = text.lower().partition("x")
    if not sep or not w.strip().isdigit() or not h.strip().isdigit() or int(w) <= 0 or int(h) <= 0:
        raise ValueError(f"{option} {text!r}: expected WIDTHxHEIGHT in pixels, e.g. 1280x800")
    return int(w), int(h)


def _find(fs: Sequence[cv2.FileStorage], key: str, names: dict[str, str]) -> tuple[str | None, cv2.FileNode | None]:
    candidates = (names[key],) if key in names else NODE_CANDIDATES[key]
    for name in candidates:
        for f in fs:
            node = f.getNode(name)
            if not node.empty():
                return name, node
    return None, None


def _matrix(node: cv2.FileNode) -> np.ndarray | None:
    if node.isSeq():
        return np.array([node.at(i).real() for i in range(node.size())], np.float64)
    m = node.mat()
    return None if m is None else np.asarray(m, np.float64)


def _missing(key: str, names: dict[str, str], path, extra: str = "") -> ValueError:
    looked = (names[key],) if key in names else NODE_CANDIDATES[key]
    hint = ""
    if key in ("R", "T") and "intrinsics" in str(path) and "extrinsics" not in str(path):
        hint = "; OpenCV's stereo_calib writes R and T to extrinsics.yml: give both files (`import_opencv` " \
               "intrinsics.yml `import_opencv` extrinsics.yml)"
    if key in DIST_KEYS:
        extra += f" (or {key}={NO_DISTORTION} for a lens without distortion)"
    return ValueError(f"{path}: no calibration node for {key!r} (looked for {', '.join(looked)}); "
                      f"map it with `node` {key}=NAME{extra}{hint}")


def _read_matrix(fs, key: str, names: dict[str, str], path, shapes: tuple[tuple[int, ...], ...]):
    if names.get(key) == NO_DISTORTION and key in DIST_KEYS:
        return NO_DISTORTION, np.zeros(5)
    name, node = _find(fs, key, names)
    if node is None:
        raise _missing(key, names, path)
    m = _matrix(node)
    if m is None or not any(m.size == int(np.prod(s)) for s in shapes):
        got = "not a matrix" if m is None else f"{m.size} values"
        raise ValueError(f"{path}: node {name!r} ({key}) must be a matrix of shape "
                         f"{' or '.join(map(str, shapes))}, got {got}")
    return name, m


def opencv_coefficients(dist: np.ndarray, node: str, path) -> np.ndarray:
    """OpenCV's 4/5/8/12/14-coefficient vector (order of
    :data:`fringe3d.optics.distortion.COEFFICIENT_NAMES`) as float64, unchanged.

    Raises ValueError naming ``node`` and ``path`` when the length is not an OpenCV one.
    """
    d = np.asarray(dist, np.float64).ravel()
    if d.size not in OPENCV_LENGTHS:
        raise ValueError(f"{path}: node {node!r} has {d.size} distortion coefficients; expected one of OpenCV's "
                         f"{', '.join(map(str, OPENCV_LENGTHS))} ({' '.join(COEFFICIENT_NAMES)})")
    return d


def _read_size(fs, key: str, names: dict[str, str], path, given, option: str, K: np.ndarray) -> tuple[int, int]:
    if given is not None:
        return int(given[0]), int(given[1])
    name, node = _find(fs, key, names)
    if node is not None:
        m = _matrix(node)
        if m is None or m.size != 2:
            raise ValueError(f"{path}: node {name!r} ({key}) must hold [width, height], got {m}")
        a, b = int(round(m.ravel()[0])), int(round(m.ravel()[1]))
        return size_order(a, b, K, str(name), key, path, option)
    pair = [(f.getNode(_SIZE_PAIRS[key][0]), f.getNode(_SIZE_PAIRS[key][1])) for f in fs]
    for wn, hn in pair:
        if not wn.empty() and not hn.empty():
            return int(wn.real()), int(hn.real())
    raise _missing(key, names, path, f" or pass {option} WxH")


def centre_offset(K: np.ndarray, width: int, height: int) -> float:
    """How far the principal point of ``K`` lies from the centre of a ``width`` x ``height``
    image: ``max(|cx - (w-1)/2| / w, |cy - (h-1)/2| / h)``; inf when it lies outside."""
    cx, cy = float(K[0, 2]), float(K[1, 2])
    if not (-0.5 <= cx <= width - 0.5 and -0.5 <= cy <= height - 0.5):
        return float("inf")
    return max(abs(cx - (width - 1) / 2) / width, abs(cy - (height - 1) / 2) / height)


def size_order(a: int, b: int, K: np.ndarray, node: str, key: str, path, option: str) -> tuple[int, int]:
    """(width, height) of the size node ``node`` holding ``[a, b]``: read as ``[w, h]``, or as
    ``[rows, cols]`` for :data:`SHAPE_NODES`, unless the principal point of ``K`` decides the
    other order (see the module doc; a :class:`CalibrationWarning` says so). A node of another
    name whose order the principal point does not decide is refused (``ValueError`` naming the
    node, the file and ``option``)."""
    K = np.asarray(K, np.float64).reshape(3, 3)
    stated = (b, a) if node in SHAPE_NODES else (a, b)
    if a == b:
        return stated
    other = (stated[1], stated[0])
    d_stated, d_other = centre_offset(K, *stated), centre_offset(K, *other)
    if d_other <= CENTRE_TOLERANCE and d_other + ORDER_MARGIN < d_stated:
        chosen = other
    elif d_stated <= CENTRE_TOLERANCE and d_stated + ORDER_MARGIN < d_other:
        chosen = stated
    elif node in SHAPE_NODES or node in NODE_CANDIDATES[key]:
        return stated  # a known node whose order the principal point does not contradict
    else:
        raise ValueError(f"{path}: node {node!r} ({key}) holds [{a}, {b}]: is it [width, height] or [rows, cols]? "
                         f"The principal point ({K[0, 2]:g}, {K[1, 2]:g}) does not tell; pass {option} WxH")
    if chosen != stated or node not in NODE_CANDIDATES[key]:
        order = "[width, height]" if chosen == (a, b) else "[rows, cols]"
        warnings.warn(f"{path}: node {node!r} ({key}) holds [{a}, {b}]; read as {order}, a {chosen[0]}x{chosen[1]} "
                      f"image, the order that centres the principal point ({K[0, 2]:g}, {K[1, 2]:g}); pass "
                      f"{option} WxH to state it", CalibrationWarning, stacklevel=4)
    return chosen


def _rotation(m: np.ndarray, node: str, path) -> np.ndarray:
    R = cv2.Rodrigues(m.reshape(3, 1))[0] if m.size == 3 else m.reshape(3, 3)
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise ValueError(f"{path}: node {node!r} (R) is not a rotation matrix (R R^T = I, det = +1)")
    return np.asarray(R, np.float64)


def load_opencv_calibration(path, names: dict[str, str] | None = None, camera_size=None, projector_size=None,
                            unit: str = "mm") -> Rig:
    """Read a camera-projector calibration from an OpenCV ``FileStorage`` YAML/XML into a :class:`Rig`.

    Parameters
    ----------
    path : str or Path, or a list of them
        ``.yaml``/``.yml``/``.xml`` (optionally ``.gz``) written by ``cv2.FileStorage``; several
        files (``intrinsics.yml`` and ``extrinsics.yml``) or a folder holding those two are read
        together, each node taken from the first file that has it.
    names : dict, optional
        Node name per key (``cam_int``, ``cam_dist``, ``proj_int``, ``proj_dist``, ``R``, ``T``,
        ``cam_size``, ``proj_size``), overriding the candidates of the module table;
        ``cam_dist``/``proj_dist`` ``"none"``: no lens distortion.
    camera_size, projector_size : (width, height), optional
        Image sizes in pixels; required when the file has no size node.
    unit : ``"mm"`` or ``"m"``
        Unit of ``T`` in the file; the rig is in mm.

    Returns
    -------
    Rig
        Pinhole camera ``[I | 0]`` (world = camera frame) and projector ``[R | T]``
        (``X_p = R X_c + T``, ``cv2.stereoCalibrate``'s convention), T in mm.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ValueError
        A node is missing (named, with the file), has the wrong shape (a distortion vector not
        of 4, 5, 8, 12 or 14 coefficients); an unknown ``unit``.

    Examples
    --------
    >>> import tempfile, os, numpy as np, cv2
    >>> f = os.path.join(tempfile.mkdtemp(), "stereo.yaml")
    >>> fs = cv2.FileStorage(f, cv2.FILE_STORAGE_WRITE)
    >>> for k, v in {"K1": np.diag([1000., 1000, 1]), "D1": np.zeros((1, 5)), "K2": np.diag([900., 900, 1]),
    ...              "D2": np.zeros((1, 5)), "R": np.eye(3), "T": np.array([[-0.1], [0], [0]])}.items():
    ...     fs.write(k, v)
    >>> fs.release()
    >>> rig = load_opencv_calibration(f, camera_size=(640, 480), projector_size=(912, 1140), unit="m")
    >>> round(rig.baseline, 6)
    100.0
    """
    paths = opencv_files(path)
    where = " + ".join(map(str, paths))
    if unit not in UNITS:
        raise ValueError(f"unit {unit!r}: expected one of {', '.join(UNITS)} (the unit of T in {where})")
    names = dict(names or {})
    fs: list[cv2.FileStorage] = []
    try:
        for p in paths:
            f = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
            if not f.isOpened():
                raise ValueError(f"{p}: not readable as an OpenCV FileStorage YAML/XML file")
            fs.append(f)
        _, Kc = _read_matrix(fs, "cam_int", names, where, ((3, 3),))
        ncd, dc = _read_matrix(fs, "cam_dist", names, where, tuple((n,) for n in OPENCV_LENGTHS))
        _, Kp = _read_matrix(fs, "proj_int", names, where, ((3, 3),))
        npd, dp = _read_matrix(fs, "proj_dist", names, where, tuple((n,) for n in OPENCV_LENGTHS))
        nR, Rm = _read_matrix(fs, "R", names, where, ((3, 3), (3,)))
        _, T = _read_matrix(fs, "T", names, where, ((3,),))
        cw, ch = _read_size(fs, "cam_size", names, where, camera_size, "`camera_size`", Kc)
        pw, ph = _read_size(fs, "proj_size", names, where, projector_size, "`projector_size`", Kp)
    finally:
        for f in fs:
            f.release()
    cam = PinholeDevice(K=Kc.reshape(3, 3), dist=opencv_coefficients(dc, ncd, where), width=cw, height=ch)
    prj = PinholeDevice(K=Kp.reshape(3, 3), dist=opencv_coefficients(dp, npd, where), width=pw, height=ph,
                        R=_rotation(Rm, nR, where), t=T.ravel() * UNITS[unit])
    return Rig(camera=cam, projector=prj)


#: The two files of OpenCV's ``stereo_calib`` sample, read together when a folder is given.
STEREO_FILES = ("intrinsics", "extrinsics")


def opencv_files(path) -> list[Path]:
    """The FileStorage files to read: ``path`` itself, each of a list of paths, or in a folder
    OpenCV's ``intrinsics`` and ``extrinsics`` files (``.yml``, ``.yaml`` or ``.xml``).
    ``FileNotFoundError`` naming what is missing."""
    items = [Path(p) for p in path] if isinstance(path, (list, tuple)) else [Path(path)]
    if not items:
        raise FileNotFoundError("no OpenCV calibration file given")
    out: list[Path] = []
    for p in items:
        if p.is_dir():
            found = [next((p / f"{stem}{ext}" for ext in (".yml", ".yaml", ".xml") if (p / f"{stem}{ext}").is_file()),
                          None) for stem in STEREO_FILES]
            if None in found:
                raise FileNotFoundError(f"{p} is a folder without OpenCV's intrinsics.yml and extrinsics.yml "
                                        "(stereo_calib's layout); give the calibration file(s) themselves")
            out += [f for f in found if f is not None]
        elif not p.is_file():
            raise FileNotFoundError(f"OpenCV calibration file not found: {p}")
        else:
            out.append(p)
    return out
