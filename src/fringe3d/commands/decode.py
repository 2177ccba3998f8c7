"""``fringe3d decode CAPTURE -o OUT``: absolute phase, modulation and mask per fringe direction."""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import typer

from fringe3d.commands import import_options as io
from fringe3d.commands.deprecated import AliasCommand
from fringe3d.commands.import_options import SRC_HELP
from fringe3d.commands.compensate_options import (check_plans_for, compensate_option, resolve_compensation,
                                                      response_option)
from fringe3d.commands.quality_options import edge_margin_option, edge_mask_option
from fringe3d.commands.checks import BIT_DEPTHS, check_choice, check_number
from fringe3d.commands.vocabulary import method_option
from fringe3d.commands.output_options import allow_empty_option, overwrite_option
from fringe3d.commands.plan_errors import in_flag_words
from fringe3d.decode import DecodeOptions, decode_capture, with_method
from fringe3d.decode.compensation import COMPENSATIONS
from fringe3d.decode.bracket import INDEX_NAME, fuse_bracket
from fringe3d.decode.plan_checks import check_geometry
from fringe3d.io.capture import read_capture, read_meta
from fringe3d.io.images import write_tiff
from fringe3d.io.importer import FrameReading, ImportLayout, load_images, parse_size
from fringe3d.patterns.manifest import MANIFEST_NAME
from fringe3d.patterns.layouts import with_threshold
from fringe3d.optics import Rig
from fringe3d.phase.ftp import WINDOWS
from fringe3d.utils.output_folder import OutputGuard, check_complete
from fringe3d.utils.console import (
    console,
    info,
    make_table,
    print_json,
    set_quiet,
    warn,
)


def _load_rig(path: Path | None):
    if path is None:
        return None
    return Rig.load(path)


def _exposure_fields(cap, fusion):
    """``decode_capture``'s ``on_cycle`` for an exposure bracket: write which exposure each pixel
    took (``exposure_index.tif``) and add the bracket's shares to the cycle's summary."""
    def on_cycle(folder: Path, s: dict) -> None:
        write_tiff(folder / INDEX_NAME, fusion.index, "exposure_index",
                   "index into capture.json exposures (the exposure fused at the pixel)")
        s["exposures"] = cap.meta["exposures"]
        s["exposure_share"] = [round(float(x), 4) for x in fusion.share]
        s["saturated_in_every_exposure"] = round(float(fusion.saturated.mean()), 4)
    return on_cycle


def register(app: typer.Typer) -> None:
    @app.command("decode", cls=AliasCommand)
    def decode_cmd(
        capture: str = typer.Argument(None, help="Capture folder: manifest.json + frames/00000.png ... "
                                                 "(+ capture.json); or, with --set/--manifest (none with "
                                                 "--list), what "
                                                "fringe3d import reads: " + SRC_HELP),
        out: Path = typer.Option(..., "-o", "--output",
                                 help="Output folder (decoded.npz, 32-bit float TIFFs, decoded.json)."),
        rig: Path = typer.Option(None, "-c", "--calibration",
                                 help="Calibration JSON (with a 'rig' entry) or rig JSON, for geometric/hybrid "
                                      "unwrapping (--rig: deprecated spelling)."),
        z_min: float = typer.Option(None, "--z-min", help="Nearest depth (mm) for geometric-constraint unwrapping."),
        min_modulation: float = typer.Option(None, "--min-modulation",
                                             help="Modulation threshold, camera counts (default 2% of full scale)."),
        bit_depth: int = io.bit_depth_option(),
        list_file: Path = io.list_option(),
        manifest: Path = io.manifest_option(),
        layout: str = io.layout_option(),
        projector_size: str = io.projector_size_option(),
        steps: int = io.steps_option(),
        period: float = io.period_option(),
        direction: str = io.direction_option(),
        shift_order: str = io.shift_order_option(),
        shift_sign: int = io.shift_sign_option(),
        unwrap: str = io.unwrap_option(),
        no_inverse: bool = io.no_inverse_option(),
        interleave: bool = io.interleave_option(),
        white_black: str = io.white_black_option(),
        threshold: str = io.threshold_option(),
        channel: str = io.channel_option(),
        first_frame: int = io.first_frame_option(),
        frame_count: int = io.frame_count_option(),
        max_cycles: int = typer.Option(None, "--max-cycles", help="Decode only the first N pattern cycles."),
        ftp_window: str = typer.Option(None, "--ftp-window",
                                       help="FTP band-pass window: hanning or circular (default hanning; circular "
                                            "for modified FTP)."),
        ftp_flip: bool = typer.Option(False, "--ftp-flip",
                                      help="Flip the FTP phase sign (a mirrored view decoded without --calibration)."),
        method: str = method_option("Unwrapping method for every direction, overriding the manifest's plans "
                                    "(e.g. spatial for a single 3-step set; gray-code-only for codes)."),
        white_thr: float = typer.Option(None, "--white-thr",
                                        help="Code-only decoding: smallest code/inverse difference (counts; "
                                             "default OpenCV's 5 at 8 bits, scaled to the bit depth)."),
        black_thr: float = typer.Option(None, "--black-thr",
                                        help="Code-only decoding: smallest white-black difference, the shadow "
                                             "mask (counts; default OpenCV's 40 at 8 bits, scaled)."),
        edge_thr: float = typer.Option(None, "--edge-thr",
                                       help="Code-only decoding: smallest code/inverse difference of a stripe-edge "
                                            "pixel's one undecided bit (counts; default 2 with inverse frames, 3 "
                                            "without, at 8 bits, scaled; 0 keeps every edge pixel)."),
        edge_mask: bool = edge_mask_option(),
        edge_margin: float = edge_margin_option(),
        compensate: str = compensate_option(),
        response: Path = response_option(),
        overwrite: bool = overwrite_option(),
        allow_empty: bool = allow_empty_option(),
        json_: bool = typer.Option(False, "--json", help="Print one JSON summary instead of a table."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars or tables."),
    ) -> None:
        """Decode a capture folder to absolute phase per fringe direction, driven by its manifest.

        A single pattern cycle is written to OUT; a sequence (the manifest repeated) to
        OUT/cycle_00000, OUT/cycle_00001, ... Invalid pixels are NaN in the phase and 0 in the mask.

        Frames that are not a capture folder decode directly with the options of fringe3d import
        (nothing is written but OUT).

        Example: fringe3d decode sphere-capture -o sphere-decoded --json

        Example: fringe3d decode 'scan/img_*.png' --set gray-code --period 8 --projector-size 1280x800 -o scan-decoded
        """
        set_quiet(quiet or json_)
        t0 = time.perf_counter()
        check_number(min_modulation, "--min-modulation", minimum=0)
        check_number(edge_margin, "--edge-margin", minimum=0)
        check_choice(bit_depth, "--bit-depth", BIT_DEPTHS)
        check_choice(ftp_window, "--ftp-window", WINDOWS)
        check_number(max_cycles, "--max-cycles", minimum=1)
        check_choice(compensate, "--compensate", COMPENSATIONS)
        described = layout is not None or manifest is not None or list_file is not None
        if capture is None and list_file is None:
            raise ValueError("give the capture folder (or frames with --set/--manifest), or --list FILE")
        if described:  # what fringe3d import reads, in memory
            size = parse_size(projector_size)
            flags = io.LayoutFlags(steps, period, direction, shift_order, shift_sign, unwrap, no_inverse, interleave,
                                   white_black, threshold)
            cap = load_images(capture, list_file=list_file, manifest=manifest,
                              layout=ImportLayout(layout, size, **io.layout_arguments(layout, flags)),
                              reading=FrameReading(channel, bit_depth, first_frame, frame_count))
            if cap.source is None and max_cycles is not None:
                cap.frames = cap.frames[:max(1, max_cycles) * len(cap.patterns)]
        else:
            layout_only = [flag for flag, given in (("--interleave", interleave),
                                                    ("--white-black", white_black != "none")) if given]
            if layout_only:
                raise ValueError(f"{' and '.join(layout_only)} describe frames being brought in (with --set, "
                                 f"--manifest or --list); the capture folder {capture}'s manifest already says how "
                                 "its frames are laid out: drop them, or import the frames again with them")
            folder = Path(capture)
            if folder.is_dir():
                check_complete(folder, "capture folder")  # an unfinished capture has no manifest yet
            if folder.is_dir() and not (folder / MANIFEST_NAME).is_file():
                raise ValueError(f"{folder} has no {MANIFEST_NAME}, so it is not a capture folder; to decode a "
                                 "folder of frames say what was projected with --set (phase-shift, gray-code, "
                                 "opencv-graycode) or --manifest FILE, as for fringe3d import")
            referenced = "source" in read_meta(folder)  # a camera file: decode it one cycle at a time
            cap = read_capture(folder, max_cycles=1 if referenced else max_cycles)
        bits = bit_depth if bit_depth is not None else cap.meta.get("bit_depth")
        fusion = None
        if cap.meta.get("exposures") is not None:  # an exposure bracket (capture/simulate/import --exposures)
            if cap.source is not None or max_cycles is not None:
                raise ValueError(f"{capture} is an exposure bracket (capture.json field exposures): it is decoded "
                                 "whole from its frames; drop --max-cycles")
            fusion = fuse_bracket(cap.frames, cap.meta["exposures"], len(cap.patterns), bits)
            cap.frames = fusion.frames
        rig_obj = _load_rig(rig)
        compensate, response_lut = resolve_compensation(compensate, response, rig_obj)
        opts = {"bit_depth": bits, "min_modulation": min_modulation, "ftp_sign": -1 if ftp_flip else 1,
                "white_thr": white_thr, "black_thr": black_thr, "edge_thr": edge_thr, "edge_mask": edge_mask,
                "edge_margin": edge_margin, "compensate": compensate}
        patterns = cap.patterns if method is None else with_method(cap.patterns, method)
        if threshold is not None:  # the plans' code threshold, also of a capture folder
            patterns = with_threshold(patterns, threshold)
        if ftp_window is not None:
            opts["ftp_window"] = ftp_window
        if rig_obj is not None and (rig_obj.projector.width, rig_obj.projector.height) != (patterns.width,
                                                                                             patterns.height):
            raise ValueError(f"the calibration {rig} describes a {rig_obj.projector.width}x{rig_obj.projector.height} "
                             f"projector but the pattern manifest is {patterns.width}x{patterns.height}: calibration "
                             "and patterns disagree (expected the calibration of the projector that showed them)")
        with in_flag_words():  # a geometric method without --calibration / --z-min: before anything is written
            check_geometry(patterns, rig_obj, z_min)
        check_plans_for(patterns, compensate)  # --compensate disagreement without two equal-step frequencies
        n = cap.cycles
        if cap.source is not None:
            total = len(cap.source) // len(patterns)
            n = total if max_cycles is None else min(max(1, max_cycles), total)
        results: list[dict] = []
        options = {k: v for k, v in opts.items()} | {"z_min": z_min, "method": method, "max_cycles": max_cycles}
        inputs = [Path(capture) if capture is not None else list_file, rig, response]
        if described:
            options |= {"src": capture, "layout": layout, "projector_size": projector_size, "channel": channel,
                        "first_frame": first_frame, "frame_count": frame_count, "steps": steps, "period": period,
                        "direction": direction, "shift_order": shift_order, "shift_sign": shift_sign,
                        "unwrap": unwrap, "no_inverse": no_inverse, "interleave": interleave,
                        "white_black": white_black, "threshold": threshold}
            inputs = io.source_inputs(capture, list_file, manifest, rig)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                dopts = DecodeOptions(z_min=z_min, response=response_lut, **opts)
                results = decode_capture(cap.source if cap.source is not None else cap.frames, patterns, out,
                                         rig=rig_obj, options=dopts, cycles=n,
                                         guard=OutputGuard(overwrite, inputs, options), allow_empty=allow_empty,
                                         name=str(capture),
                                         on_cycle=None if fusion is None else _exposure_fields(cap, fusion))
            finally:
                for msg in dict.fromkeys(str(w.message) for w in caught):
                    warn(msg)
        for d, rad in (results[0].get("info", {}).get("radiometry", {}) if results and not compensate else {}).items():
            diag = rad.get("diagnostic", {})
            if diag.get("fix"):
                um = f" (about {diag['ripple_um']:.3g} um on the surface)" if diag.get("ripple_um") else ""
                warn(f"direction {d}: {diag['fix']}{um}; here: --compensate harmonic (4 or more steps) or "
                     "--compensate response with the grey ramp of capture --response, or patterns --response")
        label = capture if capture is not None else list_file
        summary = {"capture": str(label), "out": str(out), "cycles": n, "patterns": patterns.name,
                   "frames": n * len(patterns), "shape": list(cap.frames.shape[1:]),
                   "seconds": round(time.perf_counter() - t0, 3), "results": results}
        if json_:
            print_json(summary)
            return
        if quiet:
            return
        rows = []
        for r in results:
            for d, s in r["directions"].items():
                order = s.get("order_inconsistent")  # absent from a resumed cycle decoded before issue 23
                rows.append([r["cycle"], d, s["method"], s["period"], s["valid_fraction"], s["phase_min"],
                             s["phase_max"], s["median_modulation"], "—" if order is None else float(order)])
        console.print(make_table(f"decoded {capture} -> {out}",
                                 ["cycle", "direction", "method", "period px", "valid", "phase min", "phase max",
                                  "median modulation", "order inconsistent"], rows[:40]))
        if len(rows) > 40:
            info(f"... {len(rows) - 40} more rows (use --json for all)")
