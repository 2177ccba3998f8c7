"""A camera that replays recorded frames as a free-running camera delivers them.

:class:`ReplayCamera` implements the :class:`fringe3d.devices.Camera` protocol over a stack of
frames already in memory (a rendered moving scene, a capture folder read back): frame ``k``
arrives at ``start + k / frame_rate`` on the host clock, the stack repeats, and each frame
carries its frame id (``k``, counting every frame since :meth:`ReplayCamera.start`) and the
host time of its arrival. A consumer that is late finds the frame waiting, stamped with the
time it arrived (it sat in the buffer as it would in a driver's); one more than a buffer
behind loses the oldest frames, as a camera's ring buffer overwrites them: their ids are
skipped.

The virtual camera's exposure control is a gain on the replayed signal
(:attr:`ReplayCamera.gain`, a factor; 1 replays the frames as recorded), clipped at the
frames' full scale like a sensor saturating.
"""
from __future__ import annotations

import time

import numpy as np

from fringe3d.devices.base import DeviceError, Frame
from fringe3d.phase.frames import as_frame_stack

#: Frames a late consumer may fall behind before the oldest are overwritten (lost).
BUFFER_FRAMES = 32


class ReplayCamera:
    """Recorded frames delivered at a frame rate, like a free-running camera (module docstring).

    Parameters
    ----------
    frames : (F, H, W) uint8 or uint16 ndarray
        The frames, replayed in order and repeated.
    frame_rate : float
        Frames per second the camera delivers (Hz).
    bit_depth : int, optional
        Bits of the frames' full scale (default: 8 for uint8, 16 for uint16).
    clock : callable, optional
        The host clock (s), ``time.monotonic`` by default.
    """

    def __init__(self, frames: np.ndarray, frame_rate: float, bit_depth: int | None = None, clock=time.monotonic):
        self.frames = as_frame_stack(frames)
        if self.frames.dtype not in (np.uint8, np.uint16):
            raise ValueError(f"replayed frames must be uint8 or uint16 camera counts, got {self.frames.dtype}")
        if not (np.isfinite(frame_rate) and frame_rate > 0):
            raise ValueError(f"frame_rate must be a positive number of frames per second, got {frame_rate}")
        self.frame_rate = float(frame_rate)
        self.bit_depth = int(bit_depth or (8 if self.frames.dtype == np.uint8 else 16))
        self.full_scale = 2 ** self.bit_depth - 1
        self._clock = clock
        self._gain = 1.0
        self._armed = False
        self._start = 0.0
        self._next = 0
        self.lost = 0
        self.trigger_mode = "off"
        self.pixel_format = f"Mono{self.bit_depth}"
        H, W = self.frames.shape[1:]
        self.roi = (0, 0, int(W), int(H))

    # -- settings ---------------------------------------------------------------------------
    @property
    def gain(self) -> float:
        """The factor on the replayed signal (the virtual camera's exposure control); 1 = as recorded."""
        return self._gain

    @gain.setter
    def gain(self, factor: float) -> None:
        factor = float(factor)
        if not (np.isfinite(factor) and factor > 0):
            raise ValueError(f"the replay gain is a positive factor, got {factor}")
        self._gain = factor

    @property
    def exposure(self) -> float:
        """The frame period (s): a replayed frame was exposed for its whole period."""
        return 1.0 / self.frame_rate

    @exposure.setter
    def exposure(self, seconds: float) -> None:
        """Scale the signal as a longer or shorter exposure would (the gain, relative to the period)."""
        self.gain = float(seconds) * self.frame_rate

    # -- acquisition ------------------------------------------------------------------------
    def start(self) -> None:
        """Start delivering: frame 0 arrives now."""
        self._armed = True
        self._start = self._clock()
        self._next = 0

    def stop(self) -> None:
        """Stop delivering frames."""
        self._armed = False

    def trigger(self) -> None:
        """Refused: a replay runs free."""
        raise DeviceError("the replay camera runs free; it takes no software trigger")

    def grab(self, timeout: float) -> Frame:
        """The next frame, waiting for its arrival time.

        Parameters
        ----------
        timeout : float
            Seconds to wait at most.

        Returns
        -------
        Frame
            The frame, with its id and the host time it arrived (s).
        """
        if not self._armed:
            raise DeviceError("the replay camera is not acquiring (call start())")
        now = self._clock()
        newest = int(np.floor((now - self._start) * self.frame_rate))
        if newest - self._next >= BUFFER_FRAMES:  # the ring buffer overwrote the oldest frames
            skip = newest - self._next - BUFFER_FRAMES + 1
            self.lost += skip
            self._next += skip
        k = self._next
        due = self._start + k / self.frame_rate
        if due - now > timeout:
            raise TimeoutError(f"the replay camera delivers no frame within {timeout:g} s")
        if due > now:
            time.sleep(due - now)
        self._next += 1
        return Frame(image=self.image(k), frame_id=k, timestamp=k / self.frame_rate, host_time=due)

    def image(self, k: int) -> np.ndarray:
        """Frame ``k`` of the replay as delivered (the stack repeats; the gain applied).

        Parameters
        ----------
        k : int
            The frame id.

        Returns
        -------
        (H, W) ndarray
            The frame, of the replayed frames' dtype.
        """
        img = self.frames[k % len(self.frames)]
        if self._gain == 1.0:
            return img
        out = np.multiply(img, np.float32(self._gain), dtype=np.float32)
        np.minimum(out, self.full_scale, out=out)
        return np.rint(out).astype(img.dtype)

    def describe(self) -> dict:
        """What ``capture.json`` records about this camera.

        Returns
        -------
        dict
            Model, frame rate, bit depth, gain and the replay's length.
        """
        H, W = self.frames.shape[1:]
        return {"backend": "replay", "model": "fringe3d replay camera", "serial": "replay",
                "frame_rate": self.frame_rate, "bit_depth": self.bit_depth, "gain": self._gain,
                "frames": len(self.frames), "width": int(W), "height": int(H)}

    def close(self) -> None:
        """Stop delivering frames."""
        self.stop()
