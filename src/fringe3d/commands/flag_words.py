"""The library's parameter words in the command line's flag words.

Library error messages and warnings name parameters, in backticks (``\\`z_min\\```,
``\\`overwrite=True\\```); the command line shows them as its flags (``--z-min``,
``--overwrite``). :data:`FLAGS` is the one table; :func:`in_flag_words` rewrites a message
exactly: only a backticked table entry is replaced, backticks included, nothing else.
"""
from __future__ import annotations

import re

#: backticked library word -> the flag (or command) a command-line user types instead
FLAGS: dict[str, str] = {
    "accept_poor=True": "--accept-poor",
    "allow_empty=True": "--allow-empty",
    "allow_relative=True": "--allow-relative",
    "anchors": "--anchors",
    "auto=True": "--auto",
    "backend='cpu'": "--device cpu",
    "ball_bar": "--ball-bar",
    "bit_depth": "--bit-depth",
    "board": "--board",
    "camera": "--camera",
    "camera_features": "--camera-feature",
    "camera_size": "--camera-size",
    "channel": "--channel",
    "cols": "--cols",
    "compensate='harmonic'": "--compensate harmonic",
    "compensate='response'": "--compensate response --response GAMMA.json",
    "copy_frames=True": "--copy-frames",
    "cycles": "--cycles",
    "direction": "--direction",
    "first_frame": "--first-frame",
    "frame": "--frame",
    "frame_count": "--frame-count",
    "frame_rate": "--frame-rate",
    "import_opencv": "--import-opencv",
    "inner_corners": "--inner-corners",
    "interleave=True": "--interleave",
    "inverse=False": "--no-inverse",
    "kind": "--kind",
    "layout": "--set",
    "list_file": "--list",
    "manifest": "--manifest",
    "method": "--method",
    "min_modulation": "--min-modulation",
    "min_modulation_share": "--min-modulation-share",
    "node": "--node",
    "overwrite=True": "--overwrite",
    "patterns": "the pattern folder (fringe3d patterns --set calibration)",
    "pattern_gamma": "fringe3d patterns --gamma",
    "period": "--period",
    "poses": "--poses",
    "preview=True": "--preview",
    "projector": "--projector",
    "projector_size": "--projector-size",
    "reference": "--reference",
    "rig": "--calibration",
    "rows": "--rows",
    "save_gamma": "fringe3d capture --gamma",
    "shift_order": "--shift-order",
    "shift_sign": "--shift-sign",
    "spacing": "--spacing",
    "step": "--step",
    "store_layout": "--store-layout",
    "store_quality=False": "--no-store-quality",
    "sync": "--sync",
    "views": "--views",
    "thickness": "--thickness",
    "threshold": "--threshold",
    "truth": "--truth",
    "white_black": "--white-black",
    "window": "--window",
    "workers": "--threads",
    "z_min": "--z-min",
    "z_min_from": "--z-min-from",
}

_BACKTICKED = re.compile(r"`([^`\s]+)`")


def in_flag_words(message: str) -> str:
    """``message`` with each backticked library word of :data:`FLAGS` replaced by its flag.

    >>> in_flag_words("`shift_sign` must be +1 or -1, got 2")
    '--shift-sign must be +1 or -1, got 2'
    >>> in_flag_words("`dask worker SCHEDULER` and `unknown` stay as they are")
    '`dask worker SCHEDULER` and `unknown` stay as they are'
    """
    return _BACKTICKED.sub(lambda m: FLAGS.get(m.group(1), m.group(0)), message)
