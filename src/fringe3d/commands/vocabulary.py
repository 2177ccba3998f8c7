"""The command line's shared words: one definition per option that names a method or a worker count.

Every command that takes an unwrapping method builds its ``--method`` from :func:`method_option`;
method names are shown with hyphens (``gray-code``) and accepted with hyphens or underscores (the
library's spelling, ``gray_code``). Worker counts have one meaning per word: ``--processes`` is a
local Dask cluster of worker processes, ``--threads`` is frames processed at once in this process
(``--workers``, which meant one in ``reconstruct`` and the other in ``strain``, is a deprecated
alias of each, :mod:`fringe3d.commands.deprecated`). ``tests/test_vocabulary.py`` checks that
every command's options come from here.
"""
from __future__ import annotations

from typing import overload

import typer

from fringe3d.utils.console import warn

from fringe3d.patterns.method_registry import method_names


def shown(name: str) -> str:
    """A library word as the command line shows it (``gray_code`` -> ``gray-code``)."""
    return name.replace("_", "-")


def readable_list(words) -> str:
    """``a, b or c`` (never a Python list)."""
    words = [str(w) for w in words]
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def method_choices() -> list[str]:
    """Every registered unwrapping method, as the command line shows it."""
    return [shown(m) for m in method_names()]


def canonical_method(value: str | None) -> str | None:
    """The library's name of method ``value`` (hyphens or underscores); None passes through.

    Raises ValueError naming ``--method`` and the methods, as a readable list."""
    if value is None:
        return None
    known = method_names()
    name = value.strip()
    name = name if name in known else name.replace("-", "_")  # a registered name may hold a hyphen
    if name not in known:
        raise ValueError(f"--method must be one of {readable_list(method_choices())}; got {value!r}")
    return name


def method_option(help: str):
    """``--method``: a typer option default whose value arrives in the library's spelling."""
    return typer.Option(None, "--method", "-m", callback=canonical_method, metavar="<method>",
                        help=f"{help} One of: {', '.join(method_choices())}.")


PROCESSES_HELP = "Run on a local Dask cluster of N worker processes (fringe3d[dask]); the output is the same."
THREADS_HELP = "Frames processed at once on N threads in this process; the output is the same for any number."


def processes_option(help: str = PROCESSES_HELP):
    """``--processes N``: worker processes of a local Dask cluster (default: none, run here)."""
    return typer.Option(None, "--processes", help=help)


def threads_option(default: int = 1, help: str = THREADS_HELP):
    """``--threads N``: frames processed at once on threads of this process."""
    return typer.Option(default, "--threads", help=help)


# ----------------------------------------------------------------------------- pattern sets
#: Set names one command used for another set than ``fringe3d patterns --set`` means by them:
#: command -> {old word: the word for that same set}. Accepted with a warning for one release.
RENAMED_SETS: dict[str, dict[str, str]] = {
    # simulate's three-frequency was the 31-frame two-direction set that `patterns` calls calibration
    # (`patterns --set three-frequency` is 15 frames in one direction: simulate's three-frequency-v)
    "simulate": {"three-frequency": "calibration"},
    "calibrate": {"phase": "calibration"},
}


def set_option(default: str | None, help: str, *more_names: str):
    """``--set NAME``: the one option that names a pattern set, in every command."""
    return typer.Option(default, "--set", *more_names, metavar="<set>", help=help)


@overload
def set_word(command: str, value: str) -> str: ...
@overload
def set_word(command: str, value: None) -> None: ...
def set_word(command: str, value: str | None) -> str | None:
    """``value`` of ``command``'s ``--set`` with a renamed word replaced (and a warning line)."""
    new = RENAMED_SETS.get(command, {}).get(value or "")
    if new is None:
        return value
    warn(f"`{command} --set {value}` is deprecated: that set is `{new}` (the name `fringe3d patterns --set` uses "
         f"for it); use --set {new}")
    return new
