"""``fringe3d import SRC -o CAPTURE``: another lab's image sequence -> a standard capture folder."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands.deprecated import AliasCommand
from fringe3d.commands.output_options import overwrite_option
from fringe3d.utils.output_folder import open_output
from fringe3d.io.importer import import_images, parse_size
from fringe3d.utils.console import console, make_table, print_json, set_quiet


def register(app: typer.Typer) -> None:
    @app.command("import", cls=AliasCommand)
    def import_cmd(
        src: str = typer.Argument(..., help="Folder or glob of frames (PNG, TIFF, BMP, JPEG), naturally sorted "
                                            "(img_2 before img_10); or a camera file, referenced not converted: "
                                            "Photron .cih/.cihx/.mraw, a multi-page .tif, a zarr store."),
        out: Path = typer.Option(..., "-o", "--output", help="Capture folder to write (must be empty)."),
        list_file: Path = typer.Option(None, "--list", help="Text file listing the frames in projection order "
                                                            "(one path a line, relative to the file)."),
        manifest: Path = typer.Option(None, "--manifest", help="Pattern manifest (manifest.json) of what was "
                                                               "projected."),
        layout: str = typer.Option(None, "--set", "--layout",
                                   help="What was projected instead of a manifest: phase-shift, gray-code, "
                                        "opencv-graycode (OpenCV GrayCodePattern: column pairs, row pairs, "
                                        "white, black)."),
        projector_size: str = typer.Option(None, "--projector-size", help="Projector WIDTHxHEIGHT (px), e.g. "
                                                                          "1024x768; required with --set/--layout."),
        steps: int = typer.Option(3, "--steps", help="Phase-shift steps N."),
        period: float = typer.Option(None, "--period", help="Fringe period / stripe width (projector px)."),
        direction: str = typer.Option("v", "--direction", help="v (vertical stripes, columns) or h (rows)."),
        shift_order: str = typer.Option(None, "--shift-order", help="Step held by each captured frame, e.g. 2,0,1."),
        shift_sign: int = typer.Option(1, "--shift-sign", help="-1 when the shifts are -2 pi k / N."),
        unwrap: str = typer.Option(None, "--unwrap", help="Unwrapping method of the plan (none, spatial, "
                                                          "histogram, ...; default none)."),
        no_inverse: bool = typer.Option(False, "--no-inverse", help="gray-code: no inverse frames."),
        channel: str = typer.Option(None, "--channel", help="Use one colour channel (r, g, b) instead of the "
                                                            "BT.601 luma of colour frames."),
        bit_depth: int = typer.Option(None, "--bit-depth", help="Camera bit depth (10/12/14 in 16-bit files); "
                                                                "default the files' 8 / 16."),
        first_frame: int = typer.Option(0, "--first-frame", help="Camera file: frame where the first pattern "
                                                                 "cycle starts."),
        frame_count: int = typer.Option(None, "--frame-count", help="Camera file: frames to use (a multiple of "
                                                                    "the cycle; default the whole cycles left)."),
        copy_frames: bool = typer.Option(False, "--copy-frames", help="Camera file: write the frames as PNGs "
                                                                      "into frames/ instead of referencing it."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print a JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No table."),
    ) -> None:
        """Import frames with any names as a capture folder (manifest.json, frames/, capture.json).

        Example: fringe3d import 'scan/img_*.jpg' --set phase-shift --steps 3 --period 24
        --projector-size 1280x800 --unwrap spatial -o scan-capture
        """
        set_quiet(quiet or json_)
        opts: dict = {}
        if layout is not None and layout != "opencv-graycode":
            opts = {"period": period, "direction": direction, "unwrap": unwrap}
            if layout == "phase-shift":
                opts.update(steps=steps, shift_sign=shift_sign,
                            shift_order=None if shift_order is None else [int(k) for k in shift_order.split(",")])
            else:
                opts["inverse"] = not no_inverse
        src_path = Path(src)
        inputs = [p for p in (src_path if src_path.exists() else None, list_file, manifest) if p is not None]
        with open_output(out, overwrite=overwrite, inputs=inputs,
                         options={"src": src, "layout": layout, "first_frame": first_frame,
                                  "frame_count": frame_count, "copy_frames": copy_frames, **opts}) as o:
            summary = o.final_paths(import_images(src, o.path, list_file=list_file, manifest=manifest, layout=layout,
                                                  projector_size=parse_size(projector_size), channel=channel,
                                                  bit_depth=bit_depth, overwrite=True, first_frame=first_frame,
                                                  frame_count=frame_count, copy_frames=copy_frames, **opts))
        if json_:
            print_json(summary)
            return
        if not quiet:
            rows = [[k, str(v)] for k, v in summary.items() if k != "source_files"]
            if "source_files" in summary:
                rows.append(["source_files", f"{summary['source_files'][0]} ... ({len(summary['source_files'])})"])
            console.print(make_table(f"imported {src} -> {out}", ["field", "value"], rows))
