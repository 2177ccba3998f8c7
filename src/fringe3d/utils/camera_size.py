"""The one check that a capture's frames and the calibration's camera have the same size."""
from __future__ import annotations


def check_camera_size(capture_hw: tuple[int, ...], camera_hw: tuple[int, ...], what: str = "the capture",
                      hint: str = "") -> None:
    """Raise ``ValueError`` when ``capture_hw`` (H, W) px, the size of ``what``, is not the
    calibration's camera size ``camera_hw`` (H, W) px; ``hint`` is appended to the message."""
    H, W = (int(v) for v in capture_hw)
    ch, cw = (int(v) for v in camera_hw)
    if (H, W) != (ch, cw):
        raise ValueError(f"{what} is {W}x{H} pixels but the calibration's camera is {cw}x{ch}: "
                         f"calibration and capture sizes disagree{hint}")
