"""``fringe3d reconstruct CAPTURE --calibration FILE -o OUT``: absolute 3D point maps."""
from __future__ import annotations

import json
import time
from pathlib import Path

import typer

from fringe3d.decode import DecodeOptions
from fringe3d.io.capture import list_frame_files, read_capture
from fringe3d.commands.checks import check_number
from fringe3d.commands.output_options import allow_empty_option, overwrite_option
from fringe3d.commands.quality_options import edge_margin_option, edge_mask_option
from fringe3d.decode import decode
from fringe3d.optics import Rig
from fringe3d.utils.output_folder import open_output
from fringe3d.pipeline import check_sizes, reconstruct_cycle, reference_z_min
from fringe3d.reconstruct.sequence import (
    CaptureFrames,
    reconstruct_sequence,
    with_method,
)
from fringe3d.utils.console import (
    console,
    info,
    make_table,
    print_json,
    set_quiet,
    to_jsonable,
)
from fringe3d.utils.jsonfile import write_json

METHODS = ("none", "geometric", "two_frequency_geometric", "hierarchical", "heterodyne", "gray_code",
           "binary_code", "hybrid", "spatial", "histogram")


def empty_reason(cap, patterns, rig, min_modulation) -> str:
    """Why no 3D point survived: the decoder's reason when no phase is valid, else the geometry."""
    opts = DecodeOptions(bit_depth=cap.meta.get("bit_depth"), min_modulation=min_modulation)
    first = cap.frames[:len(patterns)]
    try:
        why = decode(first, patterns, rig=rig, options=opts).empty_reason()
    except ValueError as e:  # the decoder could not even start (e.g. geometric without z_min)
        return str(e)
    return why or ("the phase is valid but no pixel triangulated inside the calibrated volume; check that the "
                   "calibration belongs to this rig and the depth limits (--z-min)")


def register(app: typer.Typer) -> None:
    @app.command("reconstruct")
    def reconstruct_cmd(
        capture: Path = typer.Argument(..., help="Capture folder: manifest.json + frames/ (+ capture.json)."),
        calibration: Path = typer.Option(..., "--calibration", "-c",
                                         help="Calibration JSON (with a 'rig' entry) or rig JSON."),
        out: Path = typer.Option(..., "--out", "-o", help="Output folder."),
        method: str = typer.Option(None, "--method", "-m",
                                   help=f"Unwrapping method for every direction (default: the manifest's plans). "
                                        f"One of: {', '.join(METHODS)}."),
        z_min: float = typer.Option(None, "--z-min", help="Nearest depth of the scene (mm), for geometric methods."),
        z_min_from: Path = typer.Option(None, "--z-min-from",
                                        help="Propose z_min from a reference measurement (points.npy or a reconstruct "
                                             "output folder): its nearest depth minus --z-margin."),
        z_margin: float = typer.Option(5.0, "--z-margin", help="Margin (mm) below the reference's nearest depth."),
        ply: bool = typer.Option(False, "--ply", help="Also write PLY point clouds (coloured by the texture)."),
        store: bool = typer.Option(True, "--store/--no-store", help="Sequences: write the zarr point store."),
        window: int = typer.Option(None, "--window",
                                   help="Sequences: a 3D frame every N captured frames (sliding window) instead of "
                                        "one per pattern cycle."),
        triangulation: str = typer.Option("auto", "--triangulation",
                                          help="auto, fast (closed form) or lsq (Eq. 2.37)."),
        min_modulation: float = typer.Option(None, "--min-modulation", help="Modulation threshold (camera counts)."),
        max_cycles: int = typer.Option(None, "--max-cycles", help="Use only the first N pattern cycles."),
        edge_mask: bool = edge_mask_option(),
        edge_margin: float = edge_margin_option(),
        overwrite: bool = overwrite_option(),
        allow_empty: bool = allow_empty_option(),
        json_: bool = typer.Option(False, "--json", help="Print one JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars or tables."),
    ) -> None:
        """Reconstruct absolute 3D point maps from a capture and a calibration.

        One pattern cycle: OUT/points.npy ((H, W, 3) float32 mm, NaN invalid), OUT/depth.tif,
        OUT/texture.tif (+ OUT/points.ply with --ply) and OUT/reconstruct.json. A sequence:
        OUT/points.zarr (one point map per cycle or window; resumable) and/or OUT/ply/.

        Example: fringe3d reconstruct sphere-capture --calibration calib.json -o sphere-3d --ply
        """
        set_quiet(quiet or json_)
        t0 = time.perf_counter()
        if method is not None and method not in METHODS:
            raise ValueError(f"unknown --method {method!r}; expected one of {', '.join(METHODS)}")
        check_number(min_modulation, "--min-modulation", minimum=0)
        check_number(z_min, "--z-min")
        check_number(z_margin, "--z-margin", minimum=0)
        check_number(edge_margin, "--edge-margin", minimum=0)
        if max_cycles is not None and max_cycles < 1:
            raise ValueError(f"--max-cycles must be at least 1, got {max_cycles}")
        if window is not None and window < 1:
            raise ValueError(f"--window must be at least 1 frame, got {window}")
        if triangulation not in ("auto", "fast", "lsq"):
            raise ValueError(f"--triangulation must be auto, fast or lsq, got {triangulation!r}")
        if z_min_from is not None:
            if z_min is not None:
                raise ValueError("give either --z-min or --z-min-from, not both")
            z_min = reference_z_min(z_min_from, z_margin)
            info(f"z_min = {z_min:.3f} mm from {z_min_from} (nearest depth - {z_margin:g} mm)")
        rig = Rig.load(calibration)
        cap = read_capture(capture, max_cycles=1)  # checks the folder; the rest is read on demand
        check_sizes(rig, cap.frames, calibration)
        n_files = len(list_frame_files(capture))
        cycles = n_files // len(cap.patterns) if max_cycles is None else min(max_cycles, n_files // len(cap.patterns))
        ps = with_method(cap.patterns, method)
        opts = {"bit_depth": cap.meta.get("bit_depth"), "min_modulation": min_modulation, "edge_mask": edge_mask,
                "edge_margin": edge_margin}
        methods = {p.direction: p.method for p in ps.plans}
        summary = {"capture": str(capture), "calibration": str(calibration), "out": str(out), "methods": methods,
                   "z_min": z_min, "cycles": cycles, "cycle_length": len(ps), "step": window,
                   "shape": list(cap.frames.shape[1:])}
        sequence = not (cycles == 1 and window is None)
        fp_options = {"method": method, "z_min": z_min, "window": window, "triangulation": triangulation,
                      "min_modulation": min_modulation, "cycles": cycles, "ply": ply, "store": store,
                      "edge_mask": edge_mask, "edge_margin": edge_margin}
        with open_output(out, overwrite=overwrite, inputs=[capture, calibration, z_min_from], options=fp_options,
                         resumable=sequence) as o:
            if not sequence:
                r = reconstruct_cycle(cap, rig, method, z_min, triangulation=triangulation,
                                      min_modulation=min_modulation, edge_mask=edge_mask, edge_margin=edge_margin)
                if not r.mask.any() and not allow_empty:
                    raise ValueError(f"{capture}: no valid 3D point: {empty_reason(cap, ps, rig, min_modulation)}. "
                                     "Nothing was written (pass --allow-empty to write it anyway)")
                summary["files"] = {k: str(Path(v).relative_to(o.path)) for k, v in r.save(o.path, ply).items()}
                summary.update(r.summary())
                summary["path"] = r.path
            else:
                frames = CaptureFrames(capture, limit=cycles * len(ps))
                seq = reconstruct_sequence(frames, ps, rig, o.path, options=DecodeOptions(z_min=z_min, **opts),
                                           mode="window" if window else "cycle",
                                           step=window, ply=ply, store=store, progress=not (quiet or json_),
                                           triangulation=triangulation)
                seq = {k: (str(o.final_of(v)) if k in ("out", "store", "ply_dir") and v else v) for k, v in seq.items()}
                summary.update(seq)
                if seq.get("empty_frames") == seq.get("frames_3d") and not allow_empty:
                    raise ValueError(f"{capture}: no valid 3D point in any frame of the sequence: "
                                     f"{empty_reason(cap, ps, rig, min_modulation)} (pass --allow-empty to keep it)")
            summary["seconds"] = round(time.perf_counter() - t0, 3)
            write_json(o.path / "reconstruct.json", summary)
        if json_:
            print_json(summary)
            return
        if quiet:
            return
        rows = [[k, v if not isinstance(v, (dict, list)) else json.dumps(to_jsonable(v))]
                for k, v in summary.items() if k not in ("files",)]
        console.print(make_table(f"reconstructed {capture} -> {out}", ["item", "value"], rows))
        info(f"done in {summary['seconds']} s")
