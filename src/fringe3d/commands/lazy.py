"""The sub-commands, imported only when one runs.

Importing every command module costs about a second (OpenCV, SciPy and the numba kernels come
with them), which ``fringe3d --help`` and ``fringe3d --version`` need not pay. :data:`COMMANDS`
lists each sub-command's name, its module and the one-line summary ``--help`` shows;
:class:`LazyCommands` is the root command group: it lists the names from that table and imports
a module (``register(app)``) the first time its command is asked for.
``tests/test_cli_consistency.py`` checks that each summary is the first line of the command's own
help, so the table cannot drift from the modules.
"""
from __future__ import annotations

import importlib
from typing import Any, NamedTuple

import typer
import typer.main
from typer.core import TyperCommand, TyperGroup


class CommandEntry(NamedTuple):
    """One sub-command: its name, the module that registers it and its ``--help`` summary."""

    name: str
    module: str
    summary: str


#: The sub-commands in the order ``--help`` lists them.
COMMANDS: tuple[CommandEntry, ...] = (
    CommandEntry("patterns", "patterns",
                 "Generate a fringe pattern set and write it as a PNG sequence plus manifest.json."),
    CommandEntry("capture", "capture",
                 "Capture a pattern sequence with a projector and a camera into a capture folder."),
    CommandEntry("import", "import_",
                 "Import frames with any names as a capture folder (manifest.json, frames/, capture.json)."),
    CommandEntry("simulate", "simulate", "Simulate a camera-projector capture with ground truth."),
    CommandEntry("decode", "decode",
                 "Decode a capture folder to absolute phase per fringe direction, driven by its manifest."),
    CommandEntry("calibrate", "calibrate",
                 "Calibrate camera and projector from board poses (circle grid, chessboard or ChArUco)"),
    CommandEntry("calibrate-axis", "calibrate_axis",
                 "Calibrate a turntable's axis from a circle board captured at several table angles."),
    CommandEntry("response", "response",
                 "Keep the projector's measured response with the rig, in a copy of its calibration file."),
    CommandEntry("reconstruct", "reconstruct",
                 "Reconstruct absolute 3D point maps from a capture and a calibration."),
    CommandEntry("live", "live",
                 "Show camera frames as 3D in a browser, continuously: capture, decode, triangulate, draw."),
    CommandEntry("export", "export",
                 "Write a measurement in the format other tools read (PLY, VTP, E57, LAS/LAZ, MAT, STL, OBJ, GLB)."),
    CommandEntry("evaluate", "evaluate",
                 "Accuracy figures of a reconstruction: fits, VDI/VDE 2634-2-style errors, error vs truth."),
    CommandEntry("merge", "merge",
                 "Register several reconstructed views, fuse them into one cloud and mesh it."),
    CommandEntry("strain", "strain", "Track every point of an inextensible wing by geodesic distances"),
    CommandEntry("report", "report", "Write one self-contained HTML page from what RESULTS holds"),
    CommandEntry("demo", "demo", "Render a calibration session, calibrate, render a measurement scene"),
    CommandEntry("warmup", "warmup", "Compile the decode and reconstruction kernels ahead of the first frame."),
    CommandEntry("experiment", "experiment",
                 "Reproduce one of the dissertation's results in simulation, beside its own figure."),
)

_BY_NAME = {entry.name: entry for entry in COMMANDS}


def load_command(name: str) -> Any:
    """The click command of sub-command ``name``, its module imported and registered now.

    Raises ``KeyError`` for a name that is not in :data:`COMMANDS`.
    """
    entry = _BY_NAME[name]
    module = importlib.import_module(f"fringe3d.commands.{entry.module}")
    single = typer.Typer()
    module.register(single)
    return readable_help(typer.main.get_command(single))


def readable_help(command: Any) -> Any:
    """``command`` with help that reads as typed: a flag shows no ``<bool>`` value column (it takes
    no value), and extras such as ``fringe3d[dask]`` keep their brackets (not read as rich markup)."""
    for param in getattr(command, "params", []):
        if getattr(param, "is_flag", False) and not getattr(param, "count", False):
            param.metavar = ""
        if getattr(param, "help", None):
            param.help = param.help.replace("fringe3d[", "fringe3d\\[")
    made_help_option = command.get_help_option

    def get_help_option(ctx: Any) -> Any:  # click makes --help per context; it is a flag too
        option = made_help_option(ctx)
        if option is not None:
            option.metavar = ""
        return option

    command.get_help_option = get_help_option
    return command


class LazyCommands(TyperGroup):
    """Root group of the ``fringe3d`` command: sub-commands from :data:`COMMANDS`, each module
    imported on first use. While the group formats its own ``--help`` it answers with light
    stand-ins that carry only the name and summary, so listing the commands imports nothing."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._loaded: dict[str, Any] = {}
        self._listing = False

    def list_commands(self, ctx: Any) -> list[str]:
        return [entry.name for entry in COMMANDS]

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        if cmd_name not in _BY_NAME:
            return None
        if self._listing:
            return TyperCommand(name=cmd_name, help=_BY_NAME[cmd_name].summary)
        if cmd_name not in self._loaded:
            self._loaded[cmd_name] = load_command(cmd_name)
        return self._loaded[cmd_name]

    def format_help(self, ctx: Any, formatter: Any) -> None:
        self._listing = True
        try:
            super().format_help(ctx, formatter)
        finally:
            self._listing = False


def all_commands() -> dict[str, Any]:
    """Every sub-command's click command by name (imports every command module)."""
    return {entry.name: load_command(entry.name) for entry in COMMANDS}
