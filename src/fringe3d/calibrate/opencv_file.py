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
``cam_size``   ``cam_size``, ``camera_size``, ``image_size`` (``[w, h]``), else ``image_width`` +
               ``image_height``
``proj_size``  ``proj_size``, ``projector_size`` (``[w, h]``), else ``projector_width`` +
               ``projector_height``
=============  ===================================================================

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

from pathlib import Path

import cv2
import numpy as np

from fringe3d.optics import PinholeDevice, Rig
from fringe3d.optics.distortion import COEFFICIENT_NAMES, OPENCV_LENGTHS

NODE_CANDIDATES: dict[str, tuple[str, ...]] = {
    "cam_int": ("cam_int", "camera_K", "K1", "M1", "camera_matrix", "K"),
    "cam_dist": ("cam_dist", "camera_dist", "D1", "distortion_coefficients", "dist"),
    "proj_int": ("proj_int", "projector_K", "K2", "M2", "projector_matrix"),
    "proj_dist": ("proj_dist", "projector_dist", "D2", "projector_distortion_coefficients"),
    "R": ("R", "rotation"),
    "T": ("T", "translation"),
    "cam_size": ("cam_size", "camera_size", "image_size"),
    "proj_size": ("proj_size", "projector_size"),
}
_SIZE_PAIRS = {"cam_size": ("image_width", "image_height"), "proj_size": ("projector_width", "projector_height")}
UNITS = {"mm": 1.0, "m": 1000.0}


def parse_node_map(items) -> dict[str, str]:
    """``["cam_int=K1", "T=trans"]`` -> ``{"cam_int": "K1", "T": "trans"}`` (ValueError on a bad item)."""
    out: dict[str, str] = {}
    for item in items or ():
        key, sep, node = str(item).partition("=")
        if not sep or not node or key not in NODE_CANDIDATES:
            raise ValueError(f"--node {item!r}: expected KEY=NODE with KEY one of {', '.join(NODE_CANDIDATES)}")
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


def _find(fs: cv2.FileStorage, key: str, names: dict[str, str]) -> tuple[str | None, cv2.FileNode | None]:
    candidates = (names[key],) if key in names else NODE_CANDIDATES[key]
    for name in candidates:
        node = fs.getNode(name)
        if not node.empty():
            return name, node
    return None, None


def _matrix(node: cv2.FileNode) -> np.ndarray | None:
    if node.isSeq():
        return np.array([node.at(i).real() for i in range(node.size())], np.float64)
    m = node.mat()
    return None if m is None else np.asarray(m, np.float64)


def _missing(key: str, names: dict[str, str], path: Path, extra: str = "") -> ValueError:
    looked = (names[key],) if key in names else NODE_CANDIDATES[key]
    return ValueError(f"{path}: no calibration node for {key!r} (looked for {', '.join(looked)}); "
                      f"map it with --node {key}=NAME{extra}")


def _read_matrix(fs, key: str, names: dict[str, str], path: Path, shapes: tuple[tuple[int, ...], ...]):
    name, node = _find(fs, key, names)
    if node is None:
        raise _missing(key, names, path)
    m = _matrix(node)
    if m is None or not any(m.size == int(np.prod(s)) for s in shapes):
        got = "not a matrix" if m is None else f"{m.size} values"
        raise ValueError(f"{path}: node {name!r} ({key}) must be a matrix of shape "
                         f"{' or '.join(map(str, shapes))}, got {got}")
    return name, m


def opencv_coefficients(dist: np.ndarray, node: str, path: Path) -> np.ndarray:
    """OpenCV's 4/5/8/12/14-coefficient vector (order of
    :data:`fringe3d.optics.distortion.COEFFICIENT_NAMES`) as float64, unchanged.

    Raises ValueError naming ``node`` and ``path`` when the length is not an OpenCV one.
    """
    d = np.asarray(dist, np.float64).ravel()
    if d.size not in OPENCV_LENGTHS:
        raise ValueError(f"{path}: node {node!r} has {d.size} distortion coefficients; expected one of OpenCV's "
                         f"{', '.join(map(str, OPENCV_LENGTHS))} ({' '.join(COEFFICIENT_NAMES)})")
    return d


def _read_size(fs, key: str, names: dict[str, str], path: Path, given, option: str) -> tuple[int, int]:
    if given is not None:
        return int(given[0]), int(given[1])
    name, node = _find(fs, key, names)
    if node is not None:
        m = _matrix(node)
        if m is None or m.size != 2:
            raise ValueError(f"{path}: node {name!r} ({key}) must hold [width, height], got {m}")
        return int(round(m.ravel()[0])), int(round(m.ravel()[1]))
    wn, hn = (fs.getNode(n) for n in _SIZE_PAIRS[key])
    if not wn.empty() and not hn.empty():
        return int(wn.real()), int(hn.real())
    raise _missing(key, names, path, f" or pass {option} WxH")


def _rotation(m: np.ndarray, node: str, path: Path) -> np.ndarray:
    R = cv2.Rodrigues(m.reshape(3, 1))[0] if m.size == 3 else m.reshape(3, 3)
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise ValueError(f"{path}: node {node!r} (R) is not a rotation matrix (R R^T = I, det = +1)")
    return np.asarray(R, np.float64)


def load_opencv_calibration(path, names: dict[str, str] | None = None, camera_size=None, projector_size=None,
                            unit: str = "mm") -> Rig:
    """Read a camera-projector calibration from an OpenCV ``FileStorage`` YAML/XML into a :class:`Rig`.

    Parameters
    ----------
    path : str or Path
        ``.yaml``/``.yml``/``.xml`` (optionally ``.gz``) written by ``cv2.FileStorage``.
    names : dict, optional
        Node name per key (``cam_int``, ``cam_dist``, ``proj_int``, ``proj_dist``, ``R``, ``T``,
        ``cam_size``, ``proj_size``), overriding the candidates of the module table.
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
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"OpenCV calibration file not found: {path}")
    if unit not in UNITS:
        raise ValueError(f"unit {unit!r}: expected one of {', '.join(UNITS)} (the unit of T in {path})")
    names = dict(names or {})
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        raise ValueError(f"{path}: not readable as an OpenCV FileStorage YAML/XML file")
    try:
        _, Kc = _read_matrix(fs, "cam_int", names, path, ((3, 3),))
        ncd, dc = _read_matrix(fs, "cam_dist", names, path, tuple((n,) for n in OPENCV_LENGTHS))
        _, Kp = _read_matrix(fs, "proj_int", names, path, ((3, 3),))
        npd, dp = _read_matrix(fs, "proj_dist", names, path, tuple((n,) for n in OPENCV_LENGTHS))
        nR, Rm = _read_matrix(fs, "R", names, path, ((3, 3), (3,)))
        _, T = _read_matrix(fs, "T", names, path, ((3,),))
        cw, ch = _read_size(fs, "cam_size", names, path, camera_size, "--camera-size")
        pw, ph = _read_size(fs, "proj_size", names, path, projector_size, "--projector-size")
    finally:
        fs.release()
    cam = PinholeDevice(K=Kc.reshape(3, 3), dist=opencv_coefficients(dc, ncd, path), width=cw, height=ch)
    prj = PinholeDevice(K=Kp.reshape(3, 3), dist=opencv_coefficients(dp, npd, path), width=pw, height=ph,
                        R=_rotation(Rm, nR, path), t=T.ravel() * UNITS[unit])
    return Rig(camera=cam, projector=prj)
