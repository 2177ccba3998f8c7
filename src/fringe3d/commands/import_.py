"""``fringe3d import SRC -o CAPTURE``: another lab's image sequence -> a standard capture folder."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands import import_options as io
from fringe3d.commands.checks import parse_exposures
from fringe3d.commands.deprecated import AliasCommand
from fringe3d.commands.import_options import SRC_HELP
from fringe3d.commands.output_options import overwrite_option
from fringe3d.utils.output_folder import open_output
from fringe3d.io.importer import FrameReading, ImportLayout, check_source, import_images, parse_size
from fringe3d.utils.console import console, make_table, print_json, set_quiet


def register(app: typer.Typer) -> None:
    @app.command("import", cls=AliasCommand)
    def import_cmd(
        src: str = typer.Argument(None, help=SRC_HELP + " A camera file is referenced, not converted. "
                                             "None with --list."),
        out: Path = typer.Option(..., "-o", "--output", help="Capture folder to write (must be empty)."),
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
        bit_depth: int = io.bit_depth_option(),
        first_frame: int = io.first_frame_option(),
        frame_count: int = io.frame_count_option(),
        copy_frames: bool = typer.Option(False, "--copy-frames", help="Camera file: write the frames as PNGs "
                                                                      "into frames/ instead of referencing it."),
        exposures: str = typer.Option(None, help="The frames are an HDR exposure bracket: comma-separated exposure "
                                                 "times (s), shortest first, one pattern cycle per exposure in "
                                                 "that order (decode fuses them per pixel)."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print a JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No table."),
    ) -> None:
        """Import frames with any names as a capture folder (manifest.json, frames/, capture.json).

        Example: fringe3d import 'scan/img_*.jpg' --set phase-shift --steps 3 --period 24
        --projector-size 1280x800 --unwrap spatial -o scan-capture
        """
        set_quiet(quiet or json_)
        opts = io.layout_arguments(layout, io.LayoutFlags(steps, period, direction, shift_order, shift_sign, unwrap,
                                                          no_inverse, interleave, white_black, threshold))
        check_source(src, list_file)
        bracket = parse_exposures(exposures, "--exposures")
        inputs = io.source_inputs(src, list_file, manifest)
        with open_output(out, overwrite=overwrite, inputs=inputs,
                         options={"src": src, "layout": layout, "first_frame": first_frame,
                                  "frame_count": frame_count, "copy_frames": copy_frames, "exposures": bracket,
                                  **opts}) as o:
            summary = o.final_paths(import_images(src, o.path, list_file=list_file, manifest=manifest,
                                                  layout=ImportLayout(layout, parse_size(projector_size), **opts),
                                                  reading=FrameReading(channel, bit_depth, first_frame, frame_count),
                                                  overwrite=True, copy_frames=copy_frames, exposures=bracket))
        if json_:
            print_json(summary)
            return
        if not quiet:
            rows = [[k, str(v)] for k, v in summary.items() if k != "source_files"]
            if "source_files" in summary:
                rows.append(["source_files", f"{summary['source_files'][0]} ... ({len(summary['source_files'])})"])
            label = src if src is not None else list_file
            console.print(make_table(f"imported {label} -> {out}", ["field", "value"], rows))
