"""The ``genicam`` camera: any vendor's camera through its GenTL producer, with harvesters.

``GenICamCamera(producer, serial)`` loads the GenTL producer (``.cti`` file, path given by the
user: it ships with the vendor's SDK), opens the camera with that serial number (the first one
when empty) and drives it through the standard SFNC features: ``ExposureTime`` (µs),
``Gain`` (dB), ``PixelFormat``, ``OffsetX/Y``, ``Width``, ``Height``, ``TriggerSelector=FrameStart``,
``TriggerMode``, ``TriggerSource`` (``Software`` / ``Line1``), ``TriggerSoftware``. Frames carry
the GenTL frame id and timestamp.

Spec: ``genicam:/path/to/producer.cti#SERIAL``. Needs the ``genicam`` extra
(``pip install 'fringe3d[genicam]'``, harvesters). Never tried with a physical camera.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .base import (
    DeviceError,
    DeviceNotFoundError,
    Frame,
    GenICamFeatures,
    require_module,
)


def parse_ident(ident: str) -> tuple[str, str]:
    """``/path/producer.cti#SERIAL`` -> (producer path, serial)."""
    producer, _, serial = ident.partition("#")
    if not producer:
        raise ValueError("the genicam camera needs its GenTL producer: `camera` genicam:/path/to/producer.cti#SERIAL "
                         "(the .cti file ships with the camera vendor's SDK)")
    if not Path(producer).is_file():
        raise FileNotFoundError(f"GenTL producer {producer} does not exist; give the path of the vendor's .cti file")
    return producer, serial


class GenICamCamera(GenICamFeatures):
    """A GenICam camera through harvesters (see the module docstring)."""

    def __init__(self, producer: str, serial: str = "", features: list[tuple[str, str]] | None = None):
        harvesters = require_module("genicam")
        from harvesters.core import Harvester  # noqa: F401  (module checked above)

        self._h = harvesters.core.Harvester()
        self._h.add_file(str(producer))
        self._h.update()
        infos = [{"model": getattr(i, "model", ""), "serial": getattr(i, "serial_number", ""),
                  "vendor": getattr(i, "vendor", "")} for i in self._h.device_info_list]
        idx = next((k for k, i in enumerate(infos) if not serial or i["serial"] == serial), None)
        if idx is None:
            found = "; ".join(f"{i['vendor']} {i['model']} serial {i['serial']}" for i in infos) or "no camera at all"
            raise DeviceNotFoundError(f"no camera with serial {serial!r} behind producer {producer}; found: {found}")
        self._ia = self._h.create(idx)
        self._nm = self._ia.remote_device.node_map
        self.model, self.serial, self.vendor = infos[idx]["model"], infos[idx]["serial"], infos[idx]["vendor"]
        self.producer = str(producer)
        self._trigger_mode = "off"
        for name, value in features or []:
            self.set_feature(name, value)
        self.trigger_mode = "off"

    def _feature_node(self, name: str):
        return getattr(self._nm, name, None)

    def _node_text(self, node) -> str:
        return node.to_string()

    def _set_node_text(self, node, text: str) -> None:
        node.from_string(text)

    @property
    def exposure(self) -> float:
        return float(self._nm.ExposureTime.value) * 1e-6

    @exposure.setter
    def exposure(self, seconds: float) -> None:
        self._nm.ExposureTime.value = float(seconds) * 1e6

    @property
    def gain(self) -> float:
        return float(self._nm.Gain.value)

    @gain.setter
    def gain(self, db: float) -> None:
        self._nm.Gain.value = float(db)


    def start(self) -> None:
        self._ia.start()

    def trigger(self) -> None:
        try:
            self._nm.TriggerSoftware.execute()
        except Exception as e:
            raise DeviceError(f"software trigger failed on camera {self.serial}: {e}") from None

    def grab(self, timeout: float) -> Frame:
        try:
            with self._ia.fetch(timeout=timeout) as buf:
                comp = buf.payload.components[0]
                img = np.array(comp.data, copy=True).reshape(comp.height, comp.width)
                return Frame(image=img, frame_id=int(buf.frame_id), timestamp=float(buf.timestamp_ns) * 1e-9,
                             host_time=time.monotonic())
        except Exception as e:
            if "timeout" in type(e).__name__.lower():
                raise TimeoutError(f"camera {self.serial} delivered no frame within {timeout:g} s") from None
            raise DeviceError(f"camera {self.serial}: {e}") from None

    def stop(self) -> None:
        self._ia.stop()

    def describe(self) -> dict:
        return {"backend": "genicam", "producer": self.producer, "vendor": self.vendor, "model": self.model,
                "serial": self.serial, "exposure": self.exposure, "gain": self.gain,
                "pixel_format": self.pixel_format, "roi": list(self.roi), "trigger_mode": self.trigger_mode}

    def close(self) -> None:
        try:
            self._ia.destroy()
        finally:
            self._h.reset()
