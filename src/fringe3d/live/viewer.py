"""The live view in a browser, on viser: the point cloud, the mask overlay, the figures and the controls.

:class:`ViserViewer` serves a page (``http://HOST:PORT``) with

* the point cloud of the newest 3D frame (mm, drawn in metres: ``scale = 0.001``; camera
  frame: x right, y down, z away from the camera; the view starts at the camera looking at
  the working volume), or, in the **depth** view, the newest 3D frame's depth map as a JPEG
  image (:func:`fringe3d.live.display.depth_image`: coloured by depth, masked pixels by reason,
  a colour bar in mm) inside the frame's stamp (one message per frame), which the page script
  draws into its own canvas over the 3D view (the browser draws an image without WebGL; while
  the depth view is on no cloud is sent and the cloud is hidden, so the 3D canvas has nothing
  to redraw);
* a GUI panel: **3D frames/s**, **latency median (ms)**, **latency p95 (ms)** (frame arrival
  to points handed to the page, measured by the pipeline: :mod:`fringe3d.live.stats`),
  **3D frames shown**, **points**; the controls **exposure** (the virtual camera's gain or a
  camera's exposure time), **pattern set** (when there is a choice), **colour** (by depth or
  texture), **show** (the point cloud or the depth map), **pause**, and **record**: a folder, a
  number of cycles and a button that records
  the next cycles there as a capture folder; the **mask overlay** image (texture in grey,
  masked pixels tinted by reason, :func:`fringe3d.live.display.mask_overlay`);
* under the view, the page's own figures: the frames it drew, their rate and the **display
  latency** (frame arrival to the cloud drawn in the page), timed by the page itself
  (:mod:`fringe3d.live.page_script`). The page also tells the viewer which frame it drew last:
  :meth:`ViserViewer.busy` holds the loop while :data:`IN_FLIGHT` clouds (:data:`IN_FLIGHT_DEPTH`
  depth images) are not drawn yet, so a slow page is not sent frames it cannot draw.

viser is an optional dependency (the ``live`` extra), imported when a viewer is made.
"""
from __future__ import annotations

import contextlib
import importlib
import io
import time
import warnings
from dataclasses import dataclass

import cv2
import numpy as np

from fringe3d.devices.base import MissingExtraError
from fringe3d.utils.warning_types import DeviceWarning

from .display import COLOURINGS, VIEWS
from .page_script import ACK_LABEL, SCRIPT, frame_stamp
from .session import Controls
from .stats import shown_text

#: The GUI labels of the figures, as the page shows them.
LABELS = {"fps": "3D frames/s", "latency_median": "latency median (ms)", "latency_p95": "latency p95 (ms)",
          "frames_shown": "3D frames shown", "points": "points per frame (median)", "status": "record status"}


#: Seconds the loop waits for the page to draw the last frame before it sends the next anyway.
PATIENCE = 2.0
#: Frames sent and not yet drawn at most: the next cloud is reconstructed while the page draws one.
IN_FLIGHT = 2
#: The same for depth images: the page decodes one off its main thread while it draws another, so
#: a third in flight keeps the pipeline busy (more frames drawn in alternated runs, user guide).
IN_FLIGHT_DEPTH = 3
#: JPEG quality of the depth image (OpenCV).
DEPTH_JPEG_QUALITY = 90


def require_viser():
    """The viser module, or :class:`~fringe3d.devices.MissingExtraError` naming the extra.

    Returns
    -------
    module
        ``viser``.
    """
    try:
        return importlib.import_module("viser")
    except ImportError as e:
        raise MissingExtraError(f"the live view needs the Python package 'viser', which is not installed ({e}); "
                                "install it with: pip install 'fringe3d[live]'") from None


@dataclass(frozen=True)
class ExposureControl:
    """The page's exposure slider: ``label``, ``low``, ``high``, ``step`` and the starting ``value``
    (in the unit the label names)."""

    label: str
    low: float
    high: float
    step: float
    value: float


@dataclass(frozen=True)
class ViewerSetup:
    """What the page offers.

    Attributes
    ----------
    host, port : str, int
        Where the page is served (port 0: a free port).
    choices : tuple of str
        Pattern-set names (a dropdown when more than one).
    exposure : ExposureControl or None
        The exposure slider (none without one).
    record_folder : str
        The record folder the page proposes.
    record_cycles : int
        Cycles a recording takes.
    point_size : float
        Drawn point size (mm).
    look_at : (float, float, float)
        Where the view looks first (mm, camera frame).
    """

    host: str = "127.0.0.1"
    port: int = 8080
    choices: tuple = ()
    exposure: ExposureControl | None = None
    record_folder: str = ""
    record_cycles: int = 1
    point_size: float = 1.0
    look_at: tuple = (0.0, 0.0, 400.0)


class ViserViewer:
    """The browser page (module docstring); the controls write into ``controls``.

    Parameters
    ----------
    setup : ViewerSetup
        What the page offers.
    controls : Controls
        Where the page's requests go.
    """

    def __init__(self, setup: ViewerSetup, controls: Controls):
        viser = require_viser()
        self.setup = setup
        self.controls = controls
        with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner; library code prints nothing
            self.server = viser.ViserServer(host=setup.host, port=setup.port, verbose=False)
        self.port = int(self.server.get_port())
        self._build_scene()
        self._build_gui()

    @property
    def url(self) -> str:
        """The page's address."""
        return f"http://{self.setup.host}:{self.port}"

    def _build_scene(self) -> None:
        s, sc = self.setup, self.server.scene
        sc.set_up_direction("-y")
        cam = self.server.initial_camera
        cam.position = (0.0, 0.0, 0.0)
        cam.look_at = tuple(1e-3 * np.asarray(s.look_at, float))
        cam.up = (0.0, -1.0, 0.0)
        self._cloud_args = {"point_size": s.point_size, "precision": "float32", "scale": 1e-3,  # size scales too
                            "point_shape": "square", "point_shading": "flat"}

    def _build_gui(self) -> None:
        s, gui, c = self.setup, self.server.gui, self.controls
        self._figures = {key: gui.add_text(LABELS[key], initial_value="-", disabled=True)
                         for key in ("fps", "latency_median", "latency_p95", "frames_shown", "points")}
        if s.exposure is not None:
            e = s.exposure
            slider = gui.add_slider(e.label, min=e.low, max=e.high, step=e.step, initial_value=e.value)
            slider.on_update(lambda _: setattr(c, "exposure", float(slider.value)))
        if len(s.choices) > 1:
            choice = gui.add_dropdown("pattern set", options=tuple(s.choices), initial_value=c.choice)
            choice.on_update(lambda _: setattr(c, "choice", str(choice.value)))
        colour = gui.add_dropdown("colour", options=COLOURINGS, initial_value=c.colouring)
        colour.on_update(lambda _: setattr(c, "colouring", str(colour.value)))
        view = gui.add_dropdown("show", options=VIEWS, initial_value=c.view)
        view.on_update(lambda _: setattr(c, "view", str(view.value)))
        pause = gui.add_checkbox("pause", initial_value=c.paused)
        pause.on_update(lambda _: setattr(c, "paused", bool(pause.value)))
        folder = gui.add_text("record folder", initial_value=s.record_folder)
        cycles = gui.add_number("record cycles", initial_value=int(s.record_cycles), min=1, step=1)
        button = gui.add_button("record")
        button.on_click(lambda _: self._ask_record(str(folder.value), int(cycles.value)))
        self._status = gui.add_text(LABELS["status"], initial_value="", disabled=True)
        self._overlay = gui.add_image(np.zeros((8, 8, 3), np.uint8), label="mask overlay", format="jpeg")
        self._stamp = gui.add_html(frame_stamp(0, 0.0))
        self.drawn = -1  # the last frame a page drew (0: a page runs the page script; -1: none yet)
        ack = gui.add_text(ACK_LABEL, initial_value="")
        ack.on_update(lambda _: self._acknowledged(ack.value))
        self._frames = 0
        self._sent_at = 0.0
        self._depth_sent = False
        self._cloud = None
        self._run_page_script()

    def _run_page_script(self) -> None:
        """Run the page's display-latency script (:mod:`.page_script`) in every page, now and on connect."""
        try:  # viser's own way to run JavaScript in its pages (it loads plotly.js so); kept for new pages
            from viser import _messages
            self.server._websock_server.queue_message(_messages.RunJavascriptMessage(source=SCRIPT))
        except (ImportError, AttributeError, TypeError) as e:
            warnings.warn(f"this viser ({getattr(require_viser(), '__version__', '?')}) cannot run the page's "
                          f"display-latency script ({e}); the page shows the pipeline's figures only",
                          DeviceWarning, stacklevel=3)

    def _acknowledged(self, value: str) -> None:
        try:
            self.drawn = max(self.drawn, int(value))
        except ValueError:  # typed into by hand
            pass

    def _ask_record(self, folder: str, cycles: int) -> None:
        if not folder.strip():
            self.show_status("not recorded: type a folder to record into")
            return
        self.controls.record = (folder.strip(), max(1, cycles))

    # -- the Viewer protocol ----------------------------------------------------------------
    def show_points(self, points: np.ndarray, colours: np.ndarray, arrival: float) -> None:
        """Draw the points, replacing the last frame's, and send them now, with the frame's stamp.

        Parameters
        ----------
        points : (N, 3) float32 ndarray
            Points (mm).
        colours : (N, 3) uint8 ndarray
            Their colours.
        arrival : float
            Host time (``time.monotonic()``, s) the frame's cycle arrived; sent as epoch ms in
            the same atomic update as the cloud, for the page's display latency.
        """
        arrival_ms = self._next_frame(arrival)
        with self.server.atomic():  # the page applies the cloud and its stamp together
            if self._cloud is None:
                self._cloud = self.server.scene.add_point_cloud("/points", points, colours, **self._cloud_args)
            else:  # new buffers in the same scene node: the page keeps the node and its material
                self._cloud.points = points
                self._cloud.colors = colours
                if not self._cloud.visible:
                    self._cloud.visible = True
            self._stamp.content = frame_stamp(self._frames, arrival_ms)
        self.server.flush()

    def _next_frame(self, arrival: float, depth: bool = False) -> float:
        """Count a frame sent now (a depth image or a cloud); its arrival as epoch ms (the page's clock)."""
        self._frames += 1
        self._depth_sent = depth
        self._sent_at = time.monotonic()
        return (arrival + (time.time() - time.monotonic())) * 1e3

    def show_depth(self, image: np.ndarray, arrival: float) -> None:
        """Show the depth image instead of the cloud (hidden, not updated): one message, the frame's
        stamp with the image inline (:func:`~fringe3d.live.page_script.frame_stamp`).

        Parameters
        ----------
        image : (h, w, 3) uint8 ndarray
            The depth image (:func:`fringe3d.live.display.depth_image`), sent as JPEG
            (:data:`DEPTH_JPEG_QUALITY`).
        arrival : float
            As for :meth:`show_points`.
        """
        ok, jpeg = cv2.imencode(".jpg", np.ascontiguousarray(image[..., ::-1]),
                                [cv2.IMWRITE_JPEG_QUALITY, DEPTH_JPEG_QUALITY])
        if not ok:  # OpenCV encodes any (h, w, 3) uint8 image; kept as a guard
            raise ValueError(f"the depth image of shape {image.shape} could not be encoded as JPEG")
        arrival_ms = self._next_frame(arrival, depth=True)
        with self.server.atomic():  # the page hides the cloud as it draws the image
            if self._cloud is not None and self._cloud.visible:  # nothing left for the 3D canvas to redraw
                self._cloud.visible = False
            self._stamp.content = frame_stamp(self._frames, arrival_ms, jpeg.tobytes())
        self.server.flush()

    def busy(self) -> bool:
        """Whether the page is still drawing the last frame sent (then the loop waits, not sends).

        Returns
        -------
        bool
            True when a page runs the page script (it said so when it started), has not drawn
            the last :data:`IN_FLIGHT` frames sent (:data:`IN_FLIGHT_DEPTH` when the last was
            a depth image), and the last was sent less than
            :data:`PATIENCE` s ago (a page that stopped drawing, e.g. a hidden tab, is sent
            frames again). Never for pages without the script.
        """
        limit = IN_FLIGHT_DEPTH if self._depth_sent else IN_FLIGHT
        return 0 <= self.drawn <= self._frames - limit and time.monotonic() - self._sent_at < PATIENCE

    def show_overlay(self, image: np.ndarray) -> None:
        """Show the mask overlay.

        Parameters
        ----------
        image : (h, w, 3) uint8 ndarray
            The overlay (:func:`fringe3d.live.display.mask_overlay`).
        """
        self._overlay.image = image

    def show_stats(self, summary: dict) -> None:
        """Show the figures.

        Parameters
        ----------
        summary : dict
            :meth:`fringe3d.live.stats.LiveStats.summary`.
        """
        lat = summary["latency_ms"]
        values = {"fps": shown_text(summary["fps"] if summary["frames_shown"] > 1 else None),
                  "latency_median": shown_text(lat["median"]), "latency_p95": shown_text(lat["p95"]),
                  "frames_shown": str(summary["frames_shown"]), "points": str(summary["points_median"])}
        for key, text in values.items():
            self._figures[key].value = text
        self.server.flush()

    def show_status(self, text: str) -> None:
        """Show a status line (recordings).

        Parameters
        ----------
        text : str
            The line.
        """
        self._status.value = text

    def clients(self) -> int:
        """Pages connected now.

        Returns
        -------
        int
            The number of connected pages.
        """
        return len(self.server.get_clients())

    def close(self) -> None:
        """Stop serving the page."""
        with contextlib.redirect_stdout(io.StringIO()):  # viser's "server stopped" line
            self.server.stop()
