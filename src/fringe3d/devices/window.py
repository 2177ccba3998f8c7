"""The ``window`` projector: a borderless full-screen window on one screen, 1:1, vsync-locked.

The projector is driven as a second display. :class:`WindowProjector` opens a full-screen
(borderless) pyglet window on screen ``index`` of the X display / desktop, at the screen's
native mode, and shows each image as a texture drawn pixel for pixel: nearest-neighbour
sampling, no scaling, no dithering, no colour management (fringe3d sets no ICC profile and
no gamma ramp; the OS must not apply one either), the image's top-left pixel at the screen's
top-left pixel, anything the image does not cover black. ``show`` returns after the buffer swap
(vsync) and ``glFinish``; :attr:`WindowProjector.latency` is the time from the ``show`` call to
that point, measured on every call. The time from the swap to light (the projector's own
processing, often 1-3 frames on consumer projectors) is measured with the camera by
``fringe3d capture --latency`` and added with ``display_latency``.

Needs the ``display`` extra (``pip install 'fringe3d[display]'``, pyglet).
"""
from __future__ import annotations

import time
import warnings

import numpy as np

from fringe3d.utils.warning_types import DeviceWarning

from .base import check_image_fits, require_module

#: Refresh rate assumed when the display reports none (e.g. Xvfb), Hz.
NOMINAL_REFRESH = 60.0


def list_screens() -> list[dict]:
    """The screens of the current display: index, width, height, x, y (pixels)."""
    pyglet = require_module("window")
    try:
        display = pyglet.display.get_display()
        screens = display.get_screens()
    except Exception as e:  # no X server / no DISPLAY
        raise ValueError(f"cannot open the display for the window projector ({type(e).__name__}: {e}); "
                         f"is DISPLAY set and an X server (or a desktop) running?") from None
    return [{"index": i, "width": s.width, "height": s.height, "x": s.x, "y": s.y} for i, s in enumerate(screens)]


class WindowProjector:
    """A projector as a full-screen window (see the module docstring).

    Parameters
    ----------
    screen : int
        Screen index (``list_screens()``); 0 is the first screen.
    display_latency : float
        Extra seconds from the buffer swap to light (measured with ``fringe3d capture --latency``).
    vsync : bool
        Lock buffer swaps to the vertical blank (keep on for capture).
    """

    def __init__(self, screen: int = 0, display_latency: float = 0.0, vsync: bool = True):
        pyglet = require_module("window")
        from pyglet import gl  # optional extra fringe3d[display]: imported only when a window is opened

        self._gl = gl
        screens = list_screens()
        if not 0 <= int(screen) < len(screens):
            found = "; ".join(f"{s['index']}: {s['width']}x{s['height']} at ({s['x']},{s['y']})" for s in screens)
            raise ValueError(f"screen {screen} does not exist; this display has {len(screens)} screen(s): {found}")
        self.screen = int(screen)
        scr = pyglet.display.get_display().get_screens()[self.screen]
        mode = scr.get_mode() if hasattr(scr, "get_mode") else None
        rate = float(getattr(mode, "rate", 0) or 0)
        self.refresh_reported = rate > 0
        if rate <= 0:
            warnings.warn(f"screen {screen} reports no refresh rate; assuming {NOMINAL_REFRESH:g} Hz",
                          DeviceWarning, stacklevel=2)
            rate = NOMINAL_REFRESH
        self.refresh_rate = rate
        self.width, self.height = int(scr.width), int(scr.height)
        self.display_latency = float(display_latency)
        self.latency = self.display_latency
        self._window = pyglet.window.Window(fullscreen=True, screen=scr, vsync=vsync,
                                            style=pyglet.window.Window.WINDOW_STYLE_BORDERLESS,
                                            caption="fringe3d projector")
        if (self._window.width, self._window.height) != (self.width, self.height):
            size = (self._window.width, self._window.height)
            self._window.close()
            raise ValueError(f"the full-screen window is {size[0]}x{size[1]} but screen {screen} is "
                             f"{self.width}x{self.height}; the window manager scaled it")
        self._window.set_mouse_visible(False)
        gl.glDisable(gl.GL_DITHER)
        gl.glDisable(gl.GL_BLEND)
        self._texture = None
        self._shown = 0

    def _upload(self, img: np.ndarray):
        pyglet = require_module("window")
        gl = self._gl
        h, w = img.shape[:2]
        rgba = np.empty((self.height, self.width, 4), np.uint8)
        rgba[...] = 0
        rgba[..., 3] = 255
        rgba[:h, :w, :3] = img[..., None] if img.ndim == 2 else img
        # pyglet's image origin is the bottom-left pixel: flip rows so row 0 is the top
        data = pyglet.image.ImageData(self.width, self.height, "RGBA", np.ascontiguousarray(rgba[::-1]).tobytes())
        tex = data.get_texture()
        gl.glBindTexture(tex.target, tex.id)
        gl.glTexParameteri(tex.target, gl.GL_TEXTURE_MIN_FILTER, gl.GL_NEAREST)
        gl.glTexParameteri(tex.target, gl.GL_TEXTURE_MAG_FILTER, gl.GL_NEAREST)
        return tex

    def show(self, image: np.ndarray) -> float:
        """Show ``image`` 1:1 and return the host time (``time.monotonic()``) it was presented."""
        img = check_image_fits(image, self.width, self.height, f"window projector (screen {self.screen})")
        t0 = time.monotonic()
        gl = self._gl
        win = self._window
        win.switch_to()
        win.dispatch_events()
        self._texture = self._upload(img)
        gl.glClearColor(0, 0, 0, 1)
        win.clear()
        self._texture.blit(0, 0)
        win.flip()
        gl.glFinish()
        t1 = time.monotonic()
        self.latency = (t1 - t0) + self.display_latency
        self._shown += 1
        return t1 + self.display_latency

    def describe(self) -> dict:
        return {"backend": "window", "screen": self.screen, "width": self.width, "height": self.height,
                "refresh_rate": self.refresh_rate, "refresh_reported_by_display": self.refresh_reported,
                "display_latency": self.display_latency}

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
