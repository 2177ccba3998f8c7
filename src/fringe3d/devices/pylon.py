"""The ``pylon`` camera: Basler cameras through pypylon (Basler's pylon SDK).

``PylonCamera(serial)`` opens the camera with that serial number (or user-defined name; the
first camera when empty), sets exposure (``ExposureTime`` / ``ExposureTimeAbs``, s -> µs), gain
(``Gain`` dB), pixel format (``Mono8/10/12``), ROI (``OffsetX/Y``, ``Width``, ``Height``) and the
frame-start trigger (``TriggerMode``, ``TriggerSource`` ``Software`` or ``Line1`` rising
edge for hardware sync). Frames carry pylon's ``BlockID`` as frame id and the exposure
timestamp in seconds (``TimeStamp`` / tick frequency). Any other GenICam feature can be set by
name with ``features`` (``fringe3d capture --camera-feature NAME=VALUE``), in the order given.

Basler's camera emulation (``PYLON_CAMEMU=1`` in the environment before the first pylon call,
device class ``BaslerCamEmu``, serial ``0815-0000``) is a real pylon device: its image-file
mode (``ImageFilename`` = a folder of PNG/TIFF frames, ``ImageFileMode=On``,
``TestImageSelector=Off``) serves those files in name order, one per trigger; the tests drive
the whole backend through it.

Needs the ``basler`` extra (``pip install 'fringe3d[basler]'``, pypylon).
"""
from __future__ import annotations

import time

import numpy as np

from .base import (
    DeviceError,
    DeviceNotFoundError,
    Frame,
    GenICamFeatures,
    require_module,
)


def list_cameras() -> list[dict]:
    """The cameras pylon sees: model, serial, device class, user name."""
    pylon = require_module("pylon")
    devs = pylon.TlFactory.GetInstance().EnumerateDevices()
    return [{"model": d.GetModelName(), "serial": d.GetSerialNumber(), "class": d.GetDeviceClass(),
             "name": d.GetUserDefinedName() if d.IsUserDefinedNameAvailable() else ""} for d in devs]


def _found_text(cams: list[dict]) -> str:
    if not cams:
        return ("pylon found no camera at all (check the cable, power and the camera's IP configuration; "
                "for Basler's emulator set PYLON_CAMEMU=1)")
    return "pylon found: " + "; ".join(f"{c['model']} serial {c['serial']} ({c['class']})" for c in cams)


class PylonCamera(GenICamFeatures):
    """A Basler camera (see the module docstring)."""

    def __init__(self, serial: str = "", features: list[tuple[str, str]] | None = None):
        from pypylon import genicam  # optional extra fringe3d[basler]: imported only when a Basler camera is opened

        self._pylon, self._genicam = require_module("pylon"), genicam
        pylon = self._pylon
        tl = pylon.TlFactory.GetInstance()
        devs = tl.EnumerateDevices()
        cams = list_cameras()
        chosen = None
        for d, c in zip(devs, cams):
            if not serial or serial in (c["serial"], c["name"]):
                chosen = d
                break
        if chosen is None:
            want = f"with serial or name {serial!r}" if serial else ""
            raise DeviceNotFoundError(f"no Basler camera {want} found; {_found_text(cams)}")
        try:
            self._cam = pylon.InstantCamera(tl.CreateDevice(chosen))
            self._cam.Open()
        except Exception as e:
            raise DeviceError(f"cannot open Basler camera {chosen.GetSerialNumber()}: {e}") from None
        self.model, self.serial = chosen.GetModelName(), chosen.GetSerialNumber()
        self.device_class = chosen.GetDeviceClass()
        self._trigger_mode = "off"
        self._tick = self._tick_frequency()
        for name, value in features or []:
            self.set_feature(name, value)
        self.trigger_mode = "off"

    # -- GenICam features ------------------------------------------------------------------
    def _node(self, *names):
        nm = self._cam.GetNodeMap()
        for n in names:
            node = nm.GetNode(n)
            if node is not None and self._genicam.IsAvailable(node):
                return node
        return None

    def _feature_node(self, name: str):
        return self._node(name)

    def _node_text(self, node) -> str:
        return node.ToString()

    def _set_node_text(self, node, text: str) -> None:
        node.FromString(text)

    def _tick_frequency(self) -> float:
        node = self._node("GevTimestampTickFrequency")
        try:
            return float(node.GetValue()) if node is not None else 1e9
        except Exception:
            return 1e9

    # -- settings --------------------------------------------------------------------------
    @property
    def exposure(self) -> float:
        node = self._node("ExposureTime", "ExposureTimeAbs")
        return float(node.GetValue()) * 1e-6 if node is not None else float("nan")

    @exposure.setter
    def exposure(self, seconds: float) -> None:
        node = self._node("ExposureTime", "ExposureTimeAbs")
        if node is None:
            raise ValueError(f"camera {self.model} has no exposure-time feature")
        us = float(seconds) * 1e6
        lo, hi = node.GetMin(), node.GetMax()
        if not lo <= us <= hi:
            raise ValueError(f"exposure {seconds:g} s is outside the camera's range {lo * 1e-6:g}..{hi * 1e-6:g} s")
        node.SetValue(us)

    @property
    def gain(self) -> float:
        node = self._node("Gain")
        return float(node.GetValue()) if node is not None else float("nan")

    @gain.setter
    def gain(self, db: float) -> None:
        node = self._node("Gain")
        if node is None:
            raise ValueError(f"camera {self.model} has no Gain (dB) feature; set GainRaw with `camera_features`")
        node.SetValue(float(db))


    @property
    def max_frame_rate(self) -> float | None:
        node = self._node("ResultingFrameRate", "ResultingFrameRateAbs")
        try:
            return float(node.GetValue()) if node is not None else None
        except Exception:
            return None

    # -- acquisition -----------------------------------------------------------------------
    def start(self) -> None:
        self._cam.StartGrabbing(self._pylon.GrabStrategy_OneByOne)

    def trigger(self) -> None:
        pylon = self._pylon
        try:
            if not self._cam.WaitForFrameTriggerReady(1000, pylon.TimeoutHandling_Return):
                raise DeviceError(f"camera {self.serial} was not ready for a trigger within 1 s")
            self._cam.ExecuteSoftwareTrigger()
        except DeviceError:
            raise
        except Exception as e:
            raise DeviceError(f"software trigger failed on camera {self.serial}: {e}") from None

    def grab(self, timeout: float) -> Frame:
        pylon = self._pylon
        try:
            res = self._cam.RetrieveResult(max(1, int(round(timeout * 1000))), pylon.TimeoutHandling_Return)
        except Exception as e:
            raise DeviceError(f"camera {self.serial}: {e}") from None
        if res is None or not res.IsValid():
            raise TimeoutError(f"camera {self.serial} delivered no frame within {timeout:g} s")
        try:
            if not res.GrabSucceeded():
                raise DeviceError(f"camera {self.serial}: grab failed ({res.GetErrorDescription()})")
            img = np.array(res.Array, copy=True)
            return Frame(image=img, frame_id=int(res.BlockID), timestamp=float(res.TimeStamp) / self._tick,
                         host_time=time.monotonic())
        finally:
            res.Release()

    def stop(self) -> None:
        if self._cam.IsGrabbing():
            self._cam.StopGrabbing()

    def describe(self) -> dict:
        return {"backend": "pylon", "model": self.model, "serial": self.serial, "device_class": self.device_class,
                "exposure": self.exposure, "gain": self.gain, "pixel_format": self.pixel_format,
                "roi": list(self.roi), "trigger_mode": self.trigger_mode}

    def close(self) -> None:
        try:
            self.stop()
            self._cam.Close()
        except Exception:
            pass
