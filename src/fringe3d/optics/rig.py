"""A camera-projector rig: two devices sharing one world frame.

For a pinhole camera the world frame is the camera frame (camera ``R = I, t = 0``) and the
projector carries ``[R | t]`` (Eq. 2.35-2.38). For a telecentric camera the world frame is the
projector frame (projector ``R = I, t = 0``) and the camera's ``M`` includes its pose (ch. 3).
Rig files are JSON (``Rig.save`` / ``Rig.load``).
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from fringe3d.utils.jsonfile import read_json, write_json

from .pinhole import PinholeDevice
from .rig_schema import validate_rig
from .telecentric import TelecentricCamera

RIG_FORMAT = "fringe3d-rig"
#: Units of a rig file's fields (its ``provenance``): pinhole ``K`` px, ``t`` mm, ``R`` world ->
#: device; telecentric ``M`` px per mm; ``dist`` Brown coefficients of normalised coordinates.
RIG_UNITS = {"length": "mm", "K": "px", "t": "mm", "R": "rotation matrix (world -> device)",
             "M": "px/mm (rows 0-1), px (column 3)", "dist": "1 (Brown k1 k2 p1 p2 k3)", "width": "px", "height": "px"}
#: A rig camera: pinhole (Eq. 2.8-2.18) or telecentric (Eq. 3.1-3.3).
Camera = PinholeDevice | TelecentricCamera


def device_from_dict(d: dict[str, Any], where: str) -> Camera:
    """A device from its ``to_dict`` form (``kind`` pinhole or telecentric); ``where`` names it in errors."""
    kind = d.get("kind", "pinhole")
    try:
        if kind == "pinhole":
            return PinholeDevice(K=d["K"], dist=d.get("dist", np.zeros(5)), width=int(d["width"]),
                                 height=int(d["height"]), R=d.get("R", np.eye(3)), t=d.get("t", np.zeros(3)))
        if kind == "telecentric":
            return TelecentricCamera(M=d["M"], width=int(d["width"]), height=int(d["height"]))
    except KeyError as e:
        raise ValueError(f"{where}: missing field {e.args[0]!r}") from None
    raise ValueError(f"{where}: unknown device kind {kind!r}; expected 'pinhole' or 'telecentric'")


#: The calibration files (:mod:`fringe3d.calibrate.calibration_file`) whose embedded rig ``Rig.load`` reads.
CALIBRATION_FORMAT = "fringe3d-calibration"
CALIBRATION_VERSIONS = (1,)


@dataclass(frozen=True, eq=False)
class Rig:
    """Camera + projector in one world frame (mm).

    Attributes
    ----------
    camera : PinholeDevice | TelecentricCamera
    projector : PinholeDevice
    projector_response : (inputs, response) tuple of float tuples, optional
        The projector's measured grey-level response (:class:`fringe3d.radiometry.ResponseLUT`
        as two tuples, both in [0, 1]), carried from capture to decode; a rig file with it is
        version 2 (older files, version 1, load without it).
    """

    camera: Camera
    projector: PinholeDevice
    projector_response: tuple[tuple[float, ...], tuple[float, ...]] | None = None

    @property
    def telecentric(self) -> bool:
        return isinstance(self.camera, TelecentricCamera)

    @property
    def baseline(self) -> float:
        """Distance between the camera and projector centres (mm); NaN for telecentric."""
        cam = self.camera
        if isinstance(cam, TelecentricCamera):
            return float("nan")
        return float(np.linalg.norm(self.projector.center - cam.center))

    def to_dict(self) -> dict[str, Any]:
        d = {"format": RIG_FORMAT, "version": 1, "camera": self.camera.to_dict(),
             "projector": self.projector.to_dict()}
        if self.projector_response is not None:  # version 2 only where used, so older readers keep reading
            inputs, response = self.projector_response
            d.update(version=2, projector_response={"inputs": list(inputs), "response": list(response)})
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "rig file") -> "Rig":
        """A rig from its JSON form, validated first (:func:`~fringe3d.optics.rig_schema.validate_rig`)."""
        validate_rig(d, where)
        resp = d.get("projector_response")
        table = None if resp is None else (tuple(map(float, resp["inputs"])), tuple(map(float, resp["response"])))
        return cls(camera=device_from_dict(d["camera"], "rig camera"),
                   projector=cast(PinholeDevice, device_from_dict(d["projector"], "rig projector")),
                   projector_response=table)

    def save(self, path: str | os.PathLike) -> Path:
        path = Path(path)
        write_json(path, self.to_dict(), units=RIG_UNITS)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Rig":
        d = read_json(path, "rig file")
        where = f"rig file {path}"
        if "rig" in d and "camera" not in d:  # a calibration file embeds a rig
            version = d.get("version", 1)  # absent: the first version, as every fringe3d file
            known = not isinstance(version, bool) and version in CALIBRATION_VERSIONS
            if d.get("format") != CALIBRATION_FORMAT or not known:
                raise ValueError(f"calibration file {path}: field format/version: {d.get('format')!r} version "
                                 f"{version!r} is not one this fringe3d reads ({CALIBRATION_FORMAT!r} "
                                 f"version {', '.join(map(str, CALIBRATION_VERSIONS))})")
            d, where = d["rig"], f"calibration file {path}: field rig"
        return cls.from_dict(d, where)
