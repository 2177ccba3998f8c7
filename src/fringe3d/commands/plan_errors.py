"""The plan checks' errors (:mod:`fringe3d.decode.plan_checks`) in the command line's words:
``method`` becomes ``--method``, ``z_min`` ``--z-min``, ``allow_relative`` ``--allow-relative``, each
flag from the one table, :data:`fringe3d.commands.flag_words.FLAGS`."""
from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

from fringe3d.commands.flag_words import FLAGS
from fringe3d.decode.plan_checks import MissingGeometryError, RelativePhaseError
from fringe3d.patterns.method_registry import method_facts


def _fix(method: str, z_min: float | None) -> str:
    if not method_facts(method).geometry:
        return f"{FLAGS['method']} {method}"
    return f"{FLAGS['method']} {method} {FLAGS['z_min']} {'MM' if z_min is None else f'{z_min:g}'}"


def relative_message(e: RelativePhaseError) -> str:
    """``e`` with its fixes spelled as flags."""
    return e.explain(_fix, f"drop {FLAGS['method']}", FLAGS["allow_relative=True"]) + " Nothing was written."


def geometry_message(e: MissingGeometryError, z_min_from: bool = False) -> str:
    """``e`` with the missing input spelled as a flag (``z_min_from``: the command also has
    ``--z-min-from``)."""
    what = (f"{FLAGS['rig']} FILE (the calibrated rig)" if e.missing == "rig" else
            f"{FLAGS['z_min']} MM, the scene's nearest depth in mm"
            + (f" (or {FLAGS['z_min_from']} REFERENCE)" if z_min_from else ""))
    return f"direction {e.direction!r}: method {e.method!r} needs {what}. Nothing was written."


@contextmanager
def in_flag_words(z_min_from: bool = False) -> Iterator[None]:
    """Re-raise the plan checks' errors as ValueErrors worded with flags (exit 2)."""
    try:
        yield
    except RelativePhaseError as e:
        raise ValueError(relative_message(e)) from None
    except MissingGeometryError as e:
        raise ValueError(geometry_message(e, z_min_from)) from None
