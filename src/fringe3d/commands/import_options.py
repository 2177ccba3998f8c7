"""The options that describe another lab's frames, shared by ``fringe3d import`` and ``fringe3d
decode`` (one definition each): the frame list, what was projected (``--manifest`` or
``--set/--layout`` with its parameters), the colour channel, bit depth and camera-file range."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import typer

from fringe3d.commands.vocabulary import set_option

SRC_HELP = ("Folder or glob of frames (PNG, TIFF, BMP, JPEG), naturally sorted (img_2 before img_10); or a camera "
            "file: Photron .cih/.cihx/.mraw, Phantom .cine, a multi-page .tif, a zarr store.")


def list_option() -> Path:
    return typer.Option(None, "--list", help="Text file listing the frames in projection order (one path a line, "
                                             "relative to the file), instead of SRC.")


def manifest_option() -> Path:
    return typer.Option(None, "--manifest", help="Pattern manifest (manifest.json) of what was projected.")


def layout_option() -> str:
    return set_option(None, "What was projected instead of a manifest: phase-shift, gray-code, opencv-graycode "
                            "(OpenCV GrayCodePattern: column pairs, row pairs, white, black).")


def projector_size_option() -> str:
    return typer.Option(None, "--projector-size", help="Projector WIDTHxHEIGHT (px), e.g. 1024x768; required with "
                                                       "--set/--layout.")


def steps_option() -> int:
    return typer.Option(3, "--steps", help="Phase-shift steps N.")


def period_option() -> float:
    return typer.Option(None, "--period", help="Fringe period / stripe width (projector px).")


def direction_option() -> str:
    return typer.Option("v", "--direction", help="v (vertical stripes, columns) or h (rows); v,h: both, the "
                                                 "columns' frames first (or alternating: --interleave).")


def interleave_option() -> bool:
    return typer.Option(False, "--interleave", help="--direction v,h: the directions alternate frame by frame "
                                                    "(column bit 0, row bit 0, column bit 1, ...; a bit with its "
                                                    "inverse, or a phase step), most significant bit first; a "
                                                    "direction with more bits ends alone.")


def white_black_option() -> str:
    return typer.Option("none", "--white-black", help="gray-code/phase-shift: a white then a black frame "
                                                      "'first' (before the patterns) or 'last'; default none.")


def threshold_option() -> str:
    return typer.Option(None, "--threshold", help="Code bit threshold: inverse (each bit's inverse frame), "
                                                  "white-black (their mean), average (the phase frames' mean) "
                                                  "or a fixed level in camera counts, e.g. 128; default: "
                                                  "inverse, else white-black, else average.")


def shift_order_option() -> str:
    return typer.Option(None, "--shift-order", help="Step held by each captured frame, e.g. 2,0,1.")


def shift_sign_option() -> int:
    return typer.Option(1, "--shift-sign", help="-1 when the shifts are -2 pi k / N.")


def unwrap_option() -> str:
    return typer.Option(None, "--unwrap", help="Unwrapping method of the plan (none, spatial, histogram, ...; "
                                               "default none).")


def no_inverse_option() -> bool:
    return typer.Option(False, "--no-inverse", help="gray-code: no inverse frames.")


def channel_option() -> str:
    return typer.Option(None, "--channel", help="Use one colour channel (r, g, b) instead of the BT.601 luma of "
                                                "colour frames.")


def bit_depth_option() -> int:
    return typer.Option(None, "--bit-depth", help="Camera bit depth (10/12/14 in 16-bit files); default "
                                                  "capture.json, else the files' 8 / 16.")


def first_frame_option() -> int:
    return typer.Option(0, "--first-frame", help="Camera file: frame where the first pattern cycle starts.")


def frame_count_option() -> int:
    return typer.Option(None, "--frame-count", help="Camera file: frames to use (a multiple of the cycle; default "
                                                    "the whole cycles left).")


@dataclass(frozen=True)
class LayoutFlags:
    """The values of the flags that describe a ``--set`` layout, as typed on the command line
    (:func:`layout_arguments` checks them against the layout and converts them).

    Attributes
    ----------
    steps : int
        ``--steps``: phase-shift steps N.
    period : float | None
        ``--period``: fringe period / stripe width (projector px).
    direction : str
        ``--direction``: ``v``, ``h`` or several, e.g. ``v,h``.
    shift_order : str | None
        ``--shift-order``: the step held by each captured frame, comma-separated, e.g. ``2,0,1``.
    shift_sign : int
        ``--shift-sign``: +1, or -1 for shifts ``-2 pi k / N``.
    unwrap : str | None
        ``--unwrap``: the plans' unwrapping method.
    no_inverse : bool
        ``--no-inverse``: gray-code without inverse frames.
    interleave : bool
        ``--interleave``: the directions alternate frame by frame.
    white_black : str
        ``--white-black``: ``none``, ``first`` or ``last``.
    threshold : str | None
        ``--threshold``: ``inverse``, ``white-black``, ``average`` or a level in camera counts.
    """

    steps: int = 3
    period: float | None = None
    direction: str = "v"
    shift_order: str | None = None
    shift_sign: int = 1
    unwrap: str | None = None
    no_inverse: bool = False
    interleave: bool = False
    white_black: str = "none"
    threshold: str | None = None


def layout_arguments(layout: str | None, flags: LayoutFlags) -> dict:
    """The ``--set`` parameters ``flags`` as fields of :class:`fringe3d.io.importer.ImportLayout`
    (for a manifest or ``opencv-graycode`` only ``threshold``, which
    :func:`fringe3d.io.importer.described_patterns` applies to any set): what the import records
    among its options."""
    if layout is None or layout == "opencv-graycode":
        if flags.interleave or flags.white_black != "none" or "," in flags.direction:
            raise ValueError("--direction v,h, --interleave and --white-black describe a --set gray-code or "
                             f"phase-shift layout; {'the manifest' if layout is None else layout} fixes its frames")
        return {} if flags.threshold is None else {"threshold": flags.threshold}
    opts: dict = {"period": flags.period, "direction": flags.direction, "unwrap": flags.unwrap,
                  "interleave": flags.interleave, "white_black": flags.white_black, "threshold": flags.threshold}
    if layout == "phase-shift":
        opts.update(steps=flags.steps, shift_sign=flags.shift_sign,
                    shift_order=None if flags.shift_order is None else [int(k) for k in flags.shift_order.split(",")])
    else:
        opts["inverse"] = not flags.no_inverse
    return opts


def source_inputs(src, list_file: Path | None, manifest: Path | None, *more: Path | None) -> list[Path]:
    """The input paths of an import-style source, for ``open_output``'s checks and fingerprint:
    the source folder or camera file itself, or each frame file a glob or ``--list`` names (a
    glob is no path, so the output guard could not see its folder), then the other files."""
    from fringe3d.io.importer import list_sources

    p = Path(src) if src is not None else None
    if list_file is None and p is not None and p.exists():
        frames = [p]
    else:
        try:
            frames = list_sources(src, list_file)
        except FileNotFoundError:  # the import itself reports what is missing
            frames = []
    return [x for x in (*frames, list_file, manifest, *more) if x is not None]
