"""``fringe3d decode CAPTURE -o OUT``: absolute phase, modulation and mask per fringe direction."""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import typer

from fringe3d.decode import DecodeOptions, decode, decode_sequence, with_method
from fringe3d.io.capture import read_capture, read_meta
from fringe3d.optics import Rig
from fringe3d.utils.console import (
    console,
    info,
    make_table,
    print_json,
    progress_bar,
    set_quiet,
    warn,
)


def _load_rig(path: Path | None):
    if path is None:
        return None
    return Rig.load(path)


def register(app: typer.Typer) -> None:
    @app.command("decode")
    def decode_cmd(
        capture: Path = typer.Argument(..., help="Capture folder: manifest.json + frames/00000.png ... "
                                                 "(+ capture.json)."),
        out: Path = typer.Option(..., "--out", "-o",
                                 help="Output folder (decoded.npz, 32-bit float TIFFs, decoded.json)."),
        rig: Path = typer.Option(None, "--rig", help="Rig or calibration JSON, for geometric/hybrid unwrapping."),
        z_min: float = typer.Option(None, "--z-min", help="Nearest depth (mm) for geometric-constraint unwrapping."),
        min_modulation: float = typer.Option(None, "--min-modulation",
                                             help="Modulation threshold in camera counts (default 2% of full scale)."),
        bit_depth: int = typer.Option(None, "--bit-depth",
                                      help="Camera bit depth (default capture.json or the PNG dtype)."),
        max_cycles: int = typer.Option(None, "--max-cycles", help="Decode only the first N pattern cycles."),
        ftp_window: str = typer.Option(None, "--ftp-window",
                                       help="FTP band-pass window: hanning or circular (default hanning; circular "
                                            "for modified FTP)."),
        ftp_flip: bool = typer.Option(False, "--ftp-flip",
                                      help="Flip the FTP phase sign (a mirrored view decoded without --rig)."),
        method: str = typer.Option(None, "--method",
                                   help="Unwrapping method for every direction, overriding the manifest's plans "
                                        "(e.g. spatial for a single 3-step set; gray_code_only for codes)."),
        white_thr: float = typer.Option(None, "--white-thr",
                                        help="Code-only decoding: smallest code/inverse difference (counts; "
                                             "default OpenCV's 5 at 8 bits, scaled to the bit depth)."),
        black_thr: float = typer.Option(None, "--black-thr",
                                        help="Code-only decoding: smallest white-black difference, the shadow "
                                             "mask (counts; default OpenCV's 40 at 8 bits, scaled)."),
        json_: bool = typer.Option(False, "--json", help="Print one JSON summary instead of a table."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars or tables."),
    ) -> None:
        """Decode a capture folder to absolute phase per fringe direction, driven by its manifest.

        A single pattern cycle is written to OUT; a sequence (the manifest repeated) to
        OUT/cycle_00000, OUT/cycle_00001, ... Invalid pixels are NaN in the phase and 0 in the mask.

        Example: fringe3d decode sphere-capture -o sphere-decoded --json
        """
        set_quiet(quiet or json_)
        t0 = time.perf_counter()
        referenced = "source" in read_meta(capture)  # a camera file: decode it one cycle at a time
        cap = read_capture(capture, max_cycles=1 if referenced else max_cycles)
        bits = bit_depth if bit_depth is not None else cap.meta.get("bit_depth")
        opts = {"bit_depth": bits, "min_modulation": min_modulation, "ftp_sign": -1 if ftp_flip else 1,
                "white_thr": white_thr, "black_thr": black_thr}
        patterns = cap.patterns if method is None else with_method(cap.patterns, method)
        if ftp_window is not None:
            opts["ftp_window"] = ftp_window
        rig_obj = _load_rig(rig)
        n = cap.cycles
        if cap.source is not None:
            total = len(cap.source) // len(patterns)
            n = total if max_cycles is None else min(max(1, max_cycles), total)
        options = DecodeOptions(z_min=z_min, **opts)
        decoded = (decode_sequence(cap.frames, patterns, rig=rig_obj, options=options) if cap.source is None
                   else (decode(c, patterns, rig=rig_obj, options=options) for c in cap.iter_cycles(n)))
        results = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with progress_bar("decoding", n, enabled=n > 1) as advance:
                for c, dec in enumerate(decoded):
                    folder = out if n == 1 else out / f"cycle_{c:05d}"
                    dec.save(folder)
                    s = dec.summary()
                    s["cycle"], s["folder"] = c, str(folder)
                    results.append(s)
                    advance()
        for msg in dict.fromkeys(str(w.message) for w in caught):
            warn(msg)
        summary = {"capture": str(capture), "out": str(out), "cycles": n, "patterns": patterns.name,
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
                rows.append([r["cycle"], d, s["method"], s["period"], s["valid_fraction"], s["phase_min"],
                             s["phase_max"], s["median_modulation"]])
        console.print(make_table(f"decoded {capture} -> {out}",
                                 ["cycle", "direction", "method", "period px", "valid", "phase min", "phase max",
                                  "median modulation"], rows[:40]))
        if len(rows) > 40:
            info(f"... {len(rows) - 40} more rows (use --json for all)")
