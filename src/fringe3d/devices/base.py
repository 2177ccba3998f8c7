"""The two device protocols, the frame record, device specs and the errors devices raise.

A rig is a :class:`Projector` (shows an 8-bit image full-screen, pixel for pixel) and a
:class:`Camera` (exposes on a trigger, returns frames with the camera's own frame id and
timestamp). Backends implement the protocols structurally (``typing.Protocol``): the
``window`` projector (:mod:`fringe3d.devices.window`), the ``pylon``, ``genicam`` and ``opencv``
cameras, and the simulator's ``virtual`` projector and camera
(:mod:`fringe3d.sim.virtual_devices`).

Device specs on the command line are ``BACKEND[:ID][?KEY=VALUE&...]``, e.g. ``window:1``,
``pylon:40012345``, ``genicam:/opt/vendor/lib/producer.cti#SERIAL``, ``opencv:0``,
``virtual:tiny?scene=sphere&seed=3``.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable
from urllib.parse import parse_qsl

import numpy as np

#: Trigger modes a camera may be put in.
TRIGGER_MODES = ("off", "software", "hardware")
#: Pixel formats (grey) a camera may deliver, and their bit depth.
PIXEL_FORMATS = {"Mono8": 8, "Mono10": 10, "Mono12": 12}
#: The optional extra (``pip install 'fringe3d[EXTRA]'``) and module each backend needs.
EXTRAS = {"window": ("display", "pyglet"), "pylon": ("basler", "pypylon.pylon"),
          "genicam": ("genicam", "harvesters"), "opencv": (None, "cv2")}


class DeviceError(RuntimeError):
    """A device failed while in use (disconnected, timed out, refused a setting)."""


class DeviceNotFoundError(ValueError):
    """The requested device does not exist; the message lists the devices that were found."""


class MissingExtraError(ValueError):
    """A backend's library is not installed; the message names the extra to install."""


@dataclass
class Frame:
    """One camera frame.

    Attributes
    ----------
    image : (H, W) uint8 / uint16 ndarray
    frame_id : int
        The camera's own frame counter (pylon ``BlockID``, GenTL frame id, ...).
    timestamp : float
        The camera's exposure timestamp in seconds (camera clock; 0 when the camera has none).
    host_time : float
        ``time.monotonic()`` on the host when the frame was retrieved (s).
    """

    image: np.ndarray
    frame_id: int
    timestamp: float
    host_time: float = 0.0


@runtime_checkable
class Projector(Protocol):
    """A projector driven as a display: ``show`` puts one image on it, pixel for pixel.

    Attributes: ``width``, ``height`` (pixels), ``refresh_rate`` (Hz), ``latency`` (s: the
    measured time from :meth:`show` to the image being on the screen), ``description`` (a dict
    recorded in ``capture.json``).
    """

    width: int
    height: int
    refresh_rate: float
    latency: float

    def show(self, image: np.ndarray) -> float:
        """Show ``image`` ((H, W) grey or (H, W, 3) RGB uint8, at most the projector's size,
        placed at the top-left pixel); return once it is on the screen, with the host time
        (``time.monotonic()``, s) at which it was presented."""
        ...

    def describe(self) -> dict:
        ...

    def close(self) -> None:
        ...


@runtime_checkable
class Camera(Protocol):
    """A camera: settings, trigger mode, acquisition, frames with ids and timestamps.

    ``exposure`` (s), ``gain`` (dB), ``pixel_format`` (a key of :data:`PIXEL_FORMATS`),
    ``roi`` ``(x, y, width, height)`` pixels, ``trigger_mode`` (:data:`TRIGGER_MODES`).
    """

    exposure: float
    gain: float
    pixel_format: str
    roi: tuple[int, int, int, int]
    trigger_mode: str

    def start(self) -> None:
        """Start acquisition (frame ids restart on most cameras)."""
        ...

    def trigger(self) -> None:
        """Issue a software trigger (``trigger_mode == "software"``)."""
        ...

    def grab(self, timeout: float) -> Frame:
        """The next frame; raises :class:`TimeoutError` after ``timeout`` seconds without one."""
        ...

    def stop(self) -> None:
        ...

    def describe(self) -> dict:
        """Model, serial, exposure, gain, pixel format, ROI, trigger mode (for capture.json)."""
        ...

    def close(self) -> None:
        ...


class GenICamFeatures:
    """GenICam features by name, pixel format and ROI, for cameras whose SDK exposes a node map
    (pylon, GenTL). A camera provides ``model``, ``serial`` and three node accessors:
    ``_feature_node(name)`` (the node, or None when absent), ``_node_text(node)`` and
    ``_set_node_text(node, text)`` (the SDK's string conversions)."""

    model: str
    serial: str
    _trigger_mode: str = "off"

    def _feature_node(self, name: str):  # pragma: no cover - provided by the camera
        raise NotImplementedError

    def _node_text(self, node) -> str:  # pragma: no cover - provided by the camera
        raise NotImplementedError

    def _set_node_text(self, node, text: str) -> None:  # pragma: no cover - provided by the camera
        raise NotImplementedError

    def _require_node(self, name: str):
        node = self._feature_node(name)
        if node is None:
            raise ValueError(f"camera {self.model} {self.serial} has no feature {name!r}")
        return node

    def set_feature(self, name: str, value) -> None:
        """Set any GenICam feature by name from its string form (``ValueError`` names it)."""
        node = self._require_node(name)
        try:
            self._set_node_text(node, str(value))
        except Exception as e:
            raise ValueError(f"camera {self.model} {self.serial} refused {name}={value!r}: {e}") from None

    def get_feature(self, name: str) -> str:
        """Any GenICam feature's value in its string form (``ValueError`` if the camera lacks it)."""
        return self._node_text(self._require_node(name))

    @property
    def trigger_mode(self) -> str:
        return self._trigger_mode

    @trigger_mode.setter
    def trigger_mode(self, mode: str) -> None:
        """"off", "software" or "hardware" (Line1, rising edge) on the FrameStart trigger."""
        check_trigger_mode(mode)
        if self._feature_node("TriggerSelector") is not None:
            self.set_feature("TriggerSelector", "FrameStart")
        if mode == "off":
            self.set_feature("TriggerMode", "Off")
        else:
            self.set_feature("TriggerMode", "On")
            self.set_feature("TriggerSource", "Software" if mode == "software" else "Line1")
            if mode == "hardware" and self._feature_node("TriggerActivation") is not None:
                self.set_feature("TriggerActivation", "RisingEdge")
        self._trigger_mode = mode

    @property
    def pixel_format(self) -> str:
        return self.get_feature("PixelFormat")

    @pixel_format.setter
    def pixel_format(self, fmt: str) -> None:
        check_pixel_format(fmt)
        self.set_feature("PixelFormat", fmt)

    @property
    def roi(self) -> tuple[int, int, int, int]:
        """``(x, y, width, height)`` in sensor pixels (OffsetX, OffsetY, Width, Height)."""
        x, y, w, h = (int(self.get_feature(n)) for n in ("OffsetX", "OffsetY", "Width", "Height"))
        return x, y, w, h

    @roi.setter
    def roi(self, roi) -> None:
        x, y, w, h = (int(v) for v in roi)
        # offsets to 0 first so that any new width/height fits, then the requested offsets
        for name, val in (("OffsetX", 0), ("OffsetY", 0), ("Width", w), ("Height", h), ("OffsetX", x), ("OffsetY", y)):
            self.set_feature(name, val)


@dataclass(frozen=True)
class DeviceSpec:
    """A parsed ``BACKEND[:ID][?KEY=VALUE&...]`` device spec."""

    backend: str
    ident: str = ""
    options: dict = field(default_factory=dict)

    @classmethod
    def parse(cls, text: str) -> DeviceSpec:
        text = str(text).strip()
        if not text:
            raise ValueError("empty device spec; expected BACKEND[:ID], e.g. window:1 or pylon:40012345")
        head, _, query = text.partition("?")
        backend, _, ident = head.partition(":")
        options = dict(parse_qsl(query, keep_blank_values=True)) if query else {}
        return cls(backend.strip().lower(), ident.strip(), options)


def require_module(backend: str):
    """Import the library a backend needs, or raise :class:`MissingExtraError` naming the extra."""
    extra, module = EXTRAS[backend]
    try:
        return importlib.import_module(module)
    except ImportError as e:
        hint = f"pip install 'fringe3d[{extra}]'" if extra else "pip install opencv-python-headless"
        raise MissingExtraError(f"the {backend!r} backend needs the Python package {module!r}, which is not "
                                f"installed ({e}); install it with: {hint}") from None


def option(options: dict, key: str, default, cast=str):
    """Typed value of a device-spec option, with a clear message for a bad one."""
    if key not in options:
        return default
    try:
        if cast is bool:
            return str(options[key]).lower() not in ("0", "false", "no", "off", "")
        return cast(options[key])
    except ValueError:
        raise ValueError(f"device option {key}={options[key]!r} is not a valid {cast.__name__}") from None


def check_unknown_options(spec: DeviceSpec, allowed) -> None:
    unknown = sorted(set(spec.options) - set(allowed))
    if unknown:
        raise ValueError(f"{spec.backend} device: unknown option(s) {unknown}; allowed: {sorted(allowed)}")


def check_pixel_format(fmt: str) -> int:
    """Bit depth of a pixel format; ``ValueError`` for one fringe3d does not capture."""
    if fmt not in PIXEL_FORMATS:
        raise ValueError(f"pixel format {fmt!r} is not supported; expected one of {', '.join(PIXEL_FORMATS)}")
    return PIXEL_FORMATS[fmt]


def check_trigger_mode(mode: str) -> str:
    if mode not in TRIGGER_MODES:
        raise ValueError(f"trigger mode {mode!r} is not one of {', '.join(TRIGGER_MODES)}")
    return mode


def check_image_fits(image: np.ndarray, width: int, height: int, what: str = "projector") -> np.ndarray:
    """``image`` as a C-contiguous uint8 (H, W) or (H, W, 3) array no larger than the screen."""
    img = np.asarray(image)
    if img.dtype != np.uint8:
        raise ValueError(f"the {what} shows 8-bit images; got dtype {img.dtype}")
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] != 3):
        raise ValueError(f"the {what} shows (H, W) grey or (H, W, 3) RGB images; got shape {img.shape}")
    h, w = img.shape[:2]
    if w > width or h > height:
        raise ValueError(f"the image is {w}x{h} pixels but the {what} is {width}x{height}; patterns larger than "
                         f"the screen cannot be shown 1:1 (build them at the projector's native size)")
    return np.ascontiguousarray(img)
