"""Projector and camera protocols and their backends (issue 14: real rig acquisition).

* :mod:`.base`: the :class:`Projector` and :class:`Camera` protocols, :class:`Frame`,
  :class:`DeviceSpec` (``BACKEND[:ID][?KEY=VALUE&...]``) and the errors.
* backends: ``window`` projector (:mod:`.window`, pyglet), ``pylon`` (:mod:`.pylon`, pypylon),
  ``genicam`` (:mod:`.genicam`, harvesters) and ``opencv`` (:mod:`.opencv`) cameras. The
  ``virtual`` projector and camera are the simulator's (:mod:`fringe3d.sim.virtual_devices`).
* :mod:`.acquire`: the capture loop (software / hardware sync, dropped and duplicated frame
  detection, the capture folder and its completion marker), latency and gamma measurements.
* :mod:`.session`: calibration capture (board found and still -> a pose's calibration set).

Hardware libraries are optional extras; a missing one raises :class:`MissingExtraError`
naming the extra to install.
"""
from __future__ import annotations

from .base import (
    Camera,
    DeviceError,
    DeviceNotFoundError,
    DeviceSpec,
    Frame,
    MissingExtraError,
    Projector,
    check_unknown_options,
    option,
    require_module,
)
from .genicam import GenICamCamera, parse_ident
from .opencv import OpenCVCamera
from .pylon import PylonCamera
from .window import WindowProjector

PROJECTOR_BACKENDS = ("window", "virtual")
CAMERA_BACKENDS = ("pylon", "genicam", "opencv", "virtual")


def open_projector(spec) -> Projector:
    """Open a hardware projector from a spec.

    Parameters
    ----------
    spec : str or DeviceSpec
        ``window:SCREEN[?latency=S]``.

    Returns
    -------
    Projector
        The open projector (close it, or use it as a context manager).

    ``virtual`` projectors are opened by :func:`fringe3d.sim.virtual_devices.open_virtual_rig`
    (the command layer routes them there; devices do not import the simulator).
    """
    spec = spec if isinstance(spec, DeviceSpec) else DeviceSpec.parse(spec)
    if spec.backend == "window":
        check_unknown_options(spec, {"latency", "vsync"})
        try:
            screen = int(spec.ident or 0)
        except ValueError:
            raise ValueError(f"window projector: the screen is an index (0, 1, ...), got {spec.ident!r}") from None
        return WindowProjector(screen, display_latency=option(spec.options, "latency", 0.0, float),
                               vsync=option(spec.options, "vsync", True, bool))
    raise ValueError(f"unknown projector backend {spec.backend!r}; expected one of {', '.join(PROJECTOR_BACKENDS)} "
                     f"(e.g. `projector` window:1)")


def open_camera(spec, features: list[tuple[str, str]] | None = None) -> Camera:
    """Open a hardware camera from a spec.

    Parameters
    ----------
    spec : str or DeviceSpec
        ``pylon:SERIAL``, ``genicam:PRODUCER.cti#SERIAL`` or ``opencv:INDEX``.
    features : list of (str, str), optional
        GenICam ``(name, value)`` pairs, set in order.

    Returns
    -------
    Camera
        The open camera (close it, or use it as a context manager).
    """
    spec = spec if isinstance(spec, DeviceSpec) else DeviceSpec.parse(spec)
    if spec.backend == "pylon":
        check_unknown_options(spec, set())
        return PylonCamera(spec.ident, features=features)
    if spec.backend == "genicam":
        check_unknown_options(spec, set())
        require_module("genicam")
        producer, serial = parse_ident(spec.ident)
        return GenICamCamera(producer, serial, features=features)
    if spec.backend == "opencv":
        check_unknown_options(spec, {"flush"})
        if features:
            raise ValueError("the opencv camera has no GenICam features; drop `camera_features`")
        return OpenCVCamera(spec.ident, flush=option(spec.options, "flush", 2, int))
    raise ValueError(f"unknown camera backend {spec.backend!r}; expected one of {', '.join(CAMERA_BACKENDS)} "
                     f"(e.g. `camera` pylon:40012345)")


__all__ = [
    "CAMERA_BACKENDS",
    "PROJECTOR_BACKENDS",
    "Camera",
    "DeviceError",
    "DeviceNotFoundError",
    "DeviceSpec",
    "Frame",
    "MissingExtraError",
    "Projector",
    "open_camera",
    "open_projector",
]
