"""OpenCV's solvers run single-threaded inside calibration, so a calibration is bit-reproducible.

``cv2.calibrateCamera`` and ``cv2.stereoCalibrate`` accumulate their normal equations over
parallel chunks whose order depends on thread scheduling; the sums then differ in the last
digits from run to run (about 1e-10 relative in the intrinsics, amplified to 1e-5 in derived
figures). Running them serially costs little next to decoding the poses and makes the same
session give the same calibration file, byte for byte.
"""
from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

import cv2


@contextmanager
def serial_opencv() -> Iterator[None]:
    """Within the block OpenCV runs sequentially (``cv2.setNumThreads(0)``); restored after.

    Examples
    --------
    >>> import cv2
    >>> before = cv2.getNumThreads()
    >>> with serial_opencv():
    ...     inside = cv2.getNumThreads()
    >>> inside <= 1, cv2.getNumThreads() == before
    (True, True)
    """
    threads = cv2.getNumThreads()
    cv2.setNumThreads(0)
    try:
        yield
    finally:
        cv2.setNumThreads(threads)
