"""The ``opencv`` camera: UVC webcams and whatever else ``cv2.VideoCapture`` opens.

``OpenCVCamera(index)`` opens device ``index`` (``/dev/videoN`` on Linux). Webcams have no
trigger input and no frame id: frames are free-running (``trigger_mode`` is always ``"off"``;
the capture loop then shows a pattern, waits for the latency and discards ``flush`` frames
before keeping one), the frame id is the count of frames read and the timestamp
``CAP_PROP_POS_MSEC`` (or the host time). Exposure and gain go through ``CAP_PROP_EXPOSURE`` /
``CAP_PROP_GAIN`` whose units are driver-specific. Good for demos, not for metrology: most
webcams apply auto-exposure, auto-gain and their own gamma. Never tried with a physical webcam.
"""
from __future__ import annotations

import time

import numpy as np

from .base import (
    DeviceError,
    DeviceNotFoundError,
    Frame,
    check_pixel_format,
    require_module,
)


class OpenCVCamera:
    def __init__(self, index: str = "0", flush: int = 2):
        cv2 = require_module("opencv")
        self._cv2 = cv2
        try:
            idx = int(index or 0)
        except ValueError:
            raise ValueError(f"the opencv camera is a device index (0, 1, ...), got {index!r}") from None
        self._cap = cv2.VideoCapture(idx)
        if not self._cap.isOpened():
            found = []
            for k in range(8):
                c = cv2.VideoCapture(k)
                if c.isOpened():
                    found.append(str(k))
                c.release()
            raise DeviceNotFoundError(f"OpenCV cannot open video device {idx}; devices that open: "
                                      f"{', '.join(found) if found else 'none'}")
        self.index = idx
        self.flush = int(flush)
        self._count = 0
        self._pixel_format = "Mono8"
        self._trigger_mode = "off"

    @property
    def trigger_mode(self) -> str:
        return self._trigger_mode

    @trigger_mode.setter
    def trigger_mode(self, mode: str) -> None:
        if mode == "hardware":
            raise ValueError("an OpenCV (UVC) camera has no trigger input; use `sync` software")
        self._trigger_mode = mode  # "software": emulated by flushing frames after each pattern

    @property
    def exposure(self) -> float:
        return float(self._cap.get(self._cv2.CAP_PROP_EXPOSURE))

    @exposure.setter
    def exposure(self, value: float) -> None:
        self._cap.set(self._cv2.CAP_PROP_EXPOSURE, float(value))

    @property
    def gain(self) -> float:
        return float(self._cap.get(self._cv2.CAP_PROP_GAIN))

    @gain.setter
    def gain(self, value: float) -> None:
        self._cap.set(self._cv2.CAP_PROP_GAIN, float(value))

    @property
    def pixel_format(self) -> str:
        return self._pixel_format

    @pixel_format.setter
    def pixel_format(self, fmt: str) -> None:
        if check_pixel_format(fmt) != 8:
            raise ValueError("the opencv camera delivers 8-bit frames only (Mono8)")

    @property
    def roi(self) -> tuple[int, int, int, int]:
        cv2 = self._cv2
        return (0, 0, int(self._cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(self._cap.get(cv2.CAP_PROP_FRAME_HEIGHT)))

    @roi.setter
    def roi(self, roi) -> None:
        x, y, w, h = (int(v) for v in roi)
        if x or y:
            raise ValueError("the opencv camera cannot offset its ROI; give 0,0,WIDTH,HEIGHT")
        self._cap.set(self._cv2.CAP_PROP_FRAME_WIDTH, w)
        self._cap.set(self._cv2.CAP_PROP_FRAME_HEIGHT, h)

    def start(self) -> None:
        pass

    def trigger(self) -> None:
        for _ in range(self.flush):  # drop frames exposed before the pattern was up
            self._cap.grab()

    def grab(self, timeout: float) -> Frame:
        ok, img = self._cap.read()
        if not ok or img is None:
            raise DeviceError(f"video device {self.index} returned no frame")
        if img.ndim == 3:
            img = self._cv2.cvtColor(img, self._cv2.COLOR_BGR2GRAY)
        self._count += 1
        ms = float(self._cap.get(self._cv2.CAP_PROP_POS_MSEC))
        now = time.monotonic()
        return Frame(image=np.ascontiguousarray(img), frame_id=self._count - 1,
                     timestamp=ms * 1e-3 if ms > 0 else now, host_time=now)

    def stop(self) -> None:
        pass

    def describe(self) -> dict:
        return {"backend": "opencv", "model": self._cap.getBackendName(), "serial": str(self.index),
                "exposure": self.exposure, "gain": self.gain, "pixel_format": self.pixel_format,
                "roi": list(self.roi), "trigger_mode": self.trigger_mode}

    def close(self) -> None:
        self._cap.release()
