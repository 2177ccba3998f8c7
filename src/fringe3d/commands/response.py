"""``fringe3d response``: keep the projector's measured response with the rig (issue 25)."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands.output_options import overwrite_option
from fringe3d.optics import Rig
from fringe3d.optics.rig import RIG_UNITS
from fringe3d.radiometry import load_response, with_response
from fringe3d.utils.console import console, print_json, set_quiet
from fringe3d.utils.jsonfile import read_json, write_json
from fringe3d.utils.output_folder import open_output_file
from fringe3d.utils.provenance import PROVENANCE_KEY


def rig_file_with_response(calibration: Path, response: Path) -> tuple[dict, Rig]:
    """The JSON of a rig or calibration file with the measured response of a ``gamma.json``
    put into its rig (``projector_response``, rig version 2), and that rig; read and checked
    before anything is written (``ValueError`` naming the file)."""
    lut = load_response(response)
    rig = with_response(Rig.load(calibration), lut)
    d = {k: v for k, v in read_json(calibration, "rig file").items() if k != PROVENANCE_KEY}
    if "rig" in d and "camera" not in d:
        return {**d, "rig": rig.to_dict()}, rig
    return rig.to_dict(), rig


def register(app: typer.Typer) -> None:
    @app.command("response")
    def response_cmd(
        response: Path = typer.Argument(..., help="gamma.json from fringe3d capture --response (a grey ramp on a "
                                                  "flat target)."),
        calibration: Path = typer.Option(..., "--calibration", "-c", help="Calibration JSON or rig JSON."),
        out: Path = typer.Option(..., "-o", "--output", help="The calibration/rig file to write, with the response."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print one JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No table."),
    ) -> None:
        """Keep the projector's measured response with the rig, in a copy of its calibration file.

        decode and reconstruct --compensate response then use it without --response.

        Example: fringe3d response gamma.json -c calib.json -o calib-response.json
        """
        set_quiet(quiet or json_)
        d, rig = rig_file_with_response(calibration, response)
        with open_output_file(out, overwrite=overwrite, inputs=[calibration, response]) as path:
            write_json(path, d, units=RIG_UNITS)
        levels = len(rig.projector_response[0]) if rig.projector_response else 0
        summary = {"calibration": str(calibration), "response": str(response), "output": str(out), "levels": levels}
        if json_:
            print_json(summary)
        elif not quiet:
            console.print(f"wrote {out}: the rig of {calibration} with the {levels}-level response of {response}")
