"""``fringe3d patterns``: generate a pattern set and write it as PNGs plus ``manifest.json``."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import typer

from fringe3d.io.images import read_image
from fringe3d.io.packed_patterns import write_packed
from fringe3d.io.pattern_folder import write_pattern_folder
from fringe3d.patterns import sets
from fringe3d.patterns.gamma import load_gamma
from fringe3d.radiometry import load_response
from fringe3d.utils.console import console, info, print_json, set_quiet
from fringe3d.commands.output_options import overwrite_option
from fringe3d.commands.vocabulary import set_option
from fringe3d.utils.output_folder import open_output
from fringe3d.patterns.manifest import PatternSet
from fringe3d.patterns.manifest_schema import MAX_PIXELS
from fringe3d.utils.schema import LABEL_PATTERN, MAX_SIDE

SETS = ("phase-shift", "three-frequency", "hierarchical", "gray-code", "binary-code", "psp-gray", "ftp", "modified-ftp",
        "two-frequency", "hybrid", "calibration", "optimal-angle")
#: Sets whose default periods adapt to the projector (sets.default_three_frequency_periods,
#: sets.default_hierarchical_periods): 18/21/144 and 18/144/1024 whenever they cover it.
ADAPTIVE_PERIODS = ("three-frequency", "calibration", "optimal-angle", "hierarchical")
DEFAULT_PERIODS = {"two-frequency": "18,144", "hybrid": "18,144"}
DEFAULT_STEPS = {"three-frequency": "9,3,3", "calibration": "9,3,3", "optimal-angle": "9,3,3",
                 "hierarchical": "9,3,3"}


def _numbers(text: str, what: str, cast=float) -> list:
    try:
        values = [cast(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"--{what} must be a number or a comma-separated list, got {text!r}") from None
    bad = [v for v in values if not (math.isfinite(v) and v > 0)]
    if bad or not values:
        raise ValueError(f"--{what} must be finite numbers > 0, got {text!r}")
    return values


def build_set(set_name: str, period: str | None, steps: str | None, direction: str, angle_deg: float | None,
              kind: str, width: int, height: int, bits: int | None):
    """The :class:`PatternSet` the command-line options describe (see ``fringe3d patterns --help``).

    ``direction`` may list several directions (``"v,h"``): every set but the calibration sets
    (which take them themselves) is then built per direction and the sets concatenated in that
    order into one manifest, a plan per direction."""
    directions = [d.strip() for d in direction.split(",")]
    if len(directions) == 1 or set_name in ("calibration", "optimal-angle"):
        return _build_one(set_name, period, steps, direction, angle_deg, kind, width, height, bits)
    if angle_deg is not None:
        raise ValueError(f"--angle fixes one fringe angle; --direction {direction} names several directions "
                         "(v and h have their own angles): drop --angle or give one direction")
    if len(set(directions)) != len(directions) or not all(directions):
        raise ValueError(f"--direction {direction!r}: expected distinct directions, e.g. v,h")
    parts = [_build_one(set_name, period, steps, d, None, kind, width, height, bits) for d in directions]
    out = parts[0]
    for p in parts[1:]:
        out = out.concat(p)
    return out


def _build_one(set_name: str, period: str | None, steps: str | None, direction: str, angle_deg: float | None,
               kind: str, width: int, height: int, bits: int | None):
    """One direction's set (see :func:`build_set`)."""
    if set_name not in SETS:
        raise ValueError(f"unknown pattern set {set_name!r}; choose one of {', '.join(SETS)}")
    if not (1 <= width <= MAX_SIDE and 1 <= height <= MAX_SIDE) or width * height > MAX_PIXELS:
        raise ValueError(f"--width/--height {width}x{height}: a projector side must be 1..{MAX_SIDE} pixels and a "
                         f"frame at most {MAX_PIXELS} pixels")
    for label in direction.split(","):
        if not re.fullmatch(LABEL_PATTERN, label):
            raise ValueError(f"--direction {direction!r}: a direction label becomes part of file names, so it may "
                             "hold only letters, digits, '_' and '-' (e.g. v, h, a1)")
    periods = _numbers(period or DEFAULT_PERIODS.get(set_name, "18"), "period")
    adaptive = period is None and set_name in ADAPTIVE_PERIODS  # the library picks them for this projector
    nsteps = _numbers(steps or DEFAULT_STEPS.get(set_name, "3"), "steps", int)
    angle = None if angle_deg is None else math.radians(angle_deg)
    common = dict(width=width, height=height)
    phase = dict(kind=kind, bit_depth=bits, **common)
    if set_name == "phase-shift":
        return sets.phase_shift(periods[0], nsteps[0], direction, angle, **phase)
    if set_name == "three-frequency":
        return sets.three_frequency(direction, None if adaptive else periods, nsteps, angle=angle, **phase)
    if set_name == "hierarchical":
        if adaptive:
            periods = list(sets.default_hierarchical_periods(sets.fringe_span(direction, angle, width, height)))
        return sets.hierarchical(periods, nsteps if len(nsteps) > 1 else nsteps[0], direction, angle, **phase)
    if set_name in ("gray-code", "binary-code"):
        return sets.gray_code(periods[0], direction, angle, code=set_name.split("-")[0], **common)
    if set_name == "psp-gray":
        return sets.psp_with_gray_code(periods[0], nsteps[0], direction, angle, **phase)
    if set_name == "ftp":
        return sets.ftp(periods[0], direction, angle, **phase)
    if set_name == "modified-ftp":
        return sets.modified_ftp(periods[0], direction, angle, **phase)
    if set_name in ("two-frequency", "hybrid"):
        if len(periods) != 2:
            raise ValueError(f"--period for {set_name} is 'HIGH,LOW' (e.g. 18,144), got {period!r}")
        build = sets.two_frequency if set_name == "two-frequency" else sets.hybrid
        return build(periods[0], periods[1], direction, angle, **phase)
    if set_name == "calibration":
        dirs = ("v", "h") if direction in ("v", "vh", "both") else tuple(direction.split(","))
        return sets.calibration(width, height, dirs, None if adaptive else periods, nsteps, kind=kind,
                                bit_depth=bits)
    if angle is None:
        raise ValueError("--set optimal-angle needs --angle: the optimal fringe angle alpha_opt in degrees")
    return sets.optimal_angle_calibration(angle, width, height, None if adaptive else periods, nsteps, kind=kind,
                                          bit_depth=bits)


def register(app: typer.Typer) -> None:
    @app.command("patterns")
    def patterns(
        output: Path = typer.Option(..., "-o", "--output", help="Folder to write 00000.png ... and manifest.json."),
        set_name: str = set_option("three-frequency", "Pattern set: " + ", ".join(SETS) + "."),
        period: str = typer.Option(None, help="Fringe period(s) in projector pixels, comma-separated "
                                              "(three-frequency/calibration: 18,21,144 while the beat of 1008 px "
                                              "covers the projector, else 18,21,T3 with a longer beat; "
                                              "two-frequency/hybrid: HIGH,LOW)."),
        steps: str = typer.Option(None, help="Phase-shift steps, comma-separated per period (three-frequency: 9,3,3)."),
        direction: str = typer.Option("v", help="Fringe direction: v (vertical stripes, encodes u_p), h (horizontal), "
                                                "or a label used with --angle; several, e.g. v,h, write "
                                                "both directions into one manifest (one plan each)."),
        angle: float = typer.Option(None, help="Fringe angle in degrees (0 = horizontal stripes, 90 = vertical); "
                                               "for optimal-angle: alpha_opt."),
        kind: str = typer.Option("sinusoid", help="sinusoid, square, bayer, floyd_steinberg, area_modulated or pwm."),
        width: int = typer.Option(800, help="Projector width in pixels."),
        height: int = typer.Option(600, help="Projector height in pixels."),
        bits: int = typer.Option(None, help="Output bit depth, 1 or 8 (default: 1 for binary kinds, else 8)."),
        dither_size: int = typer.Option(8, help="Bayer matrix size for --kind bayer."),
        gamma: Path = typer.Option(None, help="gamma.json from 'fringe3d capture --gamma': pre-compensate the "
                                              "8-bit patterns for the projector's gamma."),
        response: Path = typer.Option(None, help="gamma.json from 'fringe3d capture --response': pre-distort the "
                                                 "8-bit patterns through the inverse of the projector's measured "
                                                 "response table (a knee or toe a single --gamma cannot describe)."),
        pack_bitplanes: bool = typer.Option(False, "--pack-bitplanes", help="Also pack the 1-bit patterns into the "
                                            "bit-planes of RGB frames (24 per frame, bitplanes/*.png) for DLP video "
                                            "pattern mode; the manifest records which plane is which pattern."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print a JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
    ) -> None:
        """Generate a fringe pattern set and write it as a PNG sequence plus manifest.json.

        Example: fringe3d patterns --set three-frequency --direction v --width 912 --height 570 -o pats

        Example: fringe3d patterns --set psp-gray --kind square --width 912 --height 1140 --pack-bitplanes -o bin
        """
        set_quiet(quiet or json_)
        if bits is not None and bits not in (1, 8):
            raise ValueError(f"--bits must be 1 or 8, got {bits}")
        if not 1 <= dither_size <= 256:
            raise ValueError(f"--dither-size must be 1..256 (the Bayer matrix side), got {dither_size}")
        ps = build_set(set_name, period, steps, direction, angle, kind, width, height, bits)
        PatternSet.from_dict(ps.to_dict(), where="the pattern set these options describe")  # as decode reads it
        g = None
        if gamma is not None:
            g = load_gamma(gamma)
            if ps.bit_depth == 1:
                raise ValueError("--gamma pre-compensates 8-bit patterns; a 1-bit set has only black and white")
        lut = None
        if response is not None:
            if gamma is not None:
                raise ValueError("give --gamma (one exponent) or --response (the measured table), not both")
            lut = load_response(response)
            if ps.bit_depth == 1:
                raise ValueError("--response pre-distorts 8-bit patterns; a 1-bit set has only black and white")
        if pack_bitplanes and ps.bit_depth != 1:
            raise ValueError("--pack-bitplanes packs 1-bit patterns; use a binary --kind (square, bayer, ...) or "
                             "--bits 1, or a Gray-code set")
        fp = {"manifest": ps.to_dict(), "gamma": g, "dither": dither_size}
        if lut is not None:  # (only) when set, so that other runs keep their fingerprint
            fp["response"] = lut.response.tolist()
        with open_output(output, overwrite=overwrite, inputs=[gamma, response], options=fp) as o:
            paths = write_pattern_folder(ps, o.path, gamma=g, response=lut, dither_size=dither_size)
            if pack_bitplanes:
                paths += write_packed(o.path, ps, np.stack([read_image(p) for p in paths]))
        summary = {"output": str(output), "name": ps.name, "frames": len(ps), "width": ps.width,
                   "height": ps.height, "bit_depth": ps.bit_depth, "directions": ps.directions(),
                   "plans": [{"direction": p.direction, "angle_deg": math.degrees(p.angle), "method": p.method,
                              "periods": list(p.periods)} for p in ps.plans],
                   "files": [p.name for p in paths] + ["manifest.json"]}
        if json_:
            print_json(summary)
        elif not quiet:
            console.print(f"wrote {len(ps)} patterns ({ps.name}, {ps.width}x{ps.height}, "
                          f"{ps.bit_depth}-bit) and manifest.json to {output}")
            for p in summary["plans"]:
                info(f"  direction {p['direction']}: {p['method']} unwrapping, periods {p['periods']}")
