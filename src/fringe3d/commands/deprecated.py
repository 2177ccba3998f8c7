"""Deprecated option spellings, accepted for one release with a warning line on stderr.

Each sub-command that renamed an option is registered with ``cls=AliasCommand``; before click
parses the command line, :meth:`AliasCommand.parse_args` rewrites an old spelling (``--out``,
``--out=DIR``) to the new one and prints ``warning: --out is deprecated ...``. The old spellings
are not click parameters, so ``--help`` documents only the new ones.
"""
from __future__ import annotations

from typer.core import TyperCommand

from fringe3d.utils.console import warn

#: Sub-command -> {old spelling: new spelling}. Remove an entry one release after it was added.
DEPRECATED: dict[str, dict[str, str]] = {
    "import": {"--out": "--output", "--layout": "--set"},
    "simulate": {"--out": "--output", "--patterns": "--set"},
    "decode": {"--out": "--output", "--rig": "--calibration", "--layout": "--set"},
    "calibrate": {"--min-modulation": "--min-modulation-share", "--patterns": "--set", "--layout": "--set"},
    "reconstruct": {"--out": "--output", "--workers": "--processes"},
    "strain": {"--out": "--output", "--workers": "--threads", "--dask-workers": "--processes"},
}


def rewrite_deprecated(command: str, args: list[str]) -> list[str]:
    """Replace the deprecated option spellings of ``command`` in ``args`` by the current ones.

    Parameters
    ----------
    command : str
        Sub-command name (a key of :data:`DEPRECATED`).
    args : list of str
        The sub-command's arguments, as click receives them.

    Returns
    -------
    list of str
        ``args`` with each old spelling (alone or as ``OLD=VALUE``) replaced; everything after a
        ``--`` is left as it is. Each replaced spelling prints one deprecation warning on stderr.
    """
    aliases = DEPRECATED.get(command, {})
    out: list[str] = []
    warned: set[str] = set()
    for i, arg in enumerate(args):
        if arg == "--":
            out.extend(args[i:])
            break
        name, sep, value = arg.partition("=")
        new = aliases.get(name)
        if new is None:
            out.append(arg)
            continue
        if name not in warned:
            warn(f"{name} is deprecated and will be removed in the next release; use {new}")
            warned.add(name)
        out.append(new + sep + value)
    return out


class AliasCommand(TyperCommand):
    """A typer command that accepts the deprecated spellings of :data:`DEPRECATED` (with a warning)."""

    def parse_args(self, ctx, args: list[str]) -> list[str]:
        """Rewrite deprecated spellings, then parse as usual."""
        return super().parse_args(ctx, rewrite_deprecated(self.name or "", list(args)))
