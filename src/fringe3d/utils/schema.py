"""Validation of input files through pydantic models, with messages that name file, field and expectation.

Every reader of a fringe3d file kind (manifest, capture.json, rig/calibration, scene, session,
summary) validates the parsed JSON against a pydantic model before using it, so a wrong type, a
non-finite number, an out-of-range size or an unsafe label fails with one message such as::

    manifest CAP/manifest.json: field frames[3].steps: Input should be less than or equal to 1024 (got 1000000000)

Shared constrained types live here: :data:`Label` (safe as a file name), :data:`FiniteFloat`,
:data:`PositiveInt` (strict: ``true`` is not an integer) and :data:`Size` (a bounded image side).
"""
from __future__ import annotations

from typing import Annotated, Any, TypeVar

import pydantic
from pydantic import AllowInfNan, Field, StrictFloat, StrictInt

from fringe3d.utils.provenance import without_provenance

#: Largest image side (pixels) fringe3d accepts in any file; bounds memory before allocation.
MAX_SIDE = 32768
#: A label that may become part of a file name: letters, digits, ``_`` and ``-`` only.
LABEL_PATTERN = r"^[A-Za-z0-9_-]+$"

Label = Annotated[str, Field(pattern=LABEL_PATTERN, max_length=64)]
FiniteFloat = Annotated[StrictFloat | StrictInt, AllowInfNan(False)]
PositiveFloat = Annotated[StrictFloat | StrictInt, AllowInfNan(False), Field(gt=0)]
NonNegativeInt = Annotated[StrictInt, Field(ge=0)]
PositiveInt = Annotated[StrictInt, Field(ge=1)]
Size = Annotated[StrictInt, Field(ge=1, le=MAX_SIDE)]

M = TypeVar("M", bound=pydantic.BaseModel)


class Strict(pydantic.BaseModel):
    """Base of the file models: unknown fields are errors, numbers are not coerced from strings."""

    model_config = pydantic.ConfigDict(extra="forbid", strict=False, frozen=True)


class Open(pydantic.BaseModel):
    """Base of file models that carry free metadata besides their checked fields."""

    model_config = pydantic.ConfigDict(extra="allow", strict=False, frozen=True)


def field_path(loc: tuple) -> str:
    """``("frames", 3, "steps")`` -> ``"frames[3].steps"``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


_MESSAGES = {"extra_forbidden": "unknown field (not part of this file format)",
             "missing": "required field is missing"}
#: Location parts that name a union member rather than a field; schema modules add their
#: discriminator values (e.g. ``"pinhole"``).
UNION_TAGS = {"float", "int", "str", "bool", "list", "dict", "none"}
_TAG_PREFIXES = ("literal[", "constrained-", "function-", "nullable[", "lax-", "json-or-python[")


def _clean(loc: tuple) -> tuple:
    return tuple(p for p in loc if not (isinstance(p, str) and (p in UNION_TAGS or p.startswith(_TAG_PREFIXES))))


def describe(error: pydantic.ValidationError, where: str, limit: int = 5) -> str:
    """One message for a pydantic error: ``where: field PATH: what was expected (got VALUE)``, per
    problem; the alternatives of a union at one field are joined into one problem."""
    grouped: dict[tuple, list[Any]] = {}
    for e in error.errors():
        grouped.setdefault(_clean(e["loc"]), []).append(e)
    parts = []
    for loc, errs in list(grouped.items())[:limit]:
        types = {e["type"] for e in errs}
        if {"float_type", "int_type"} <= types:
            msgs = ["Input should be a number"]
        else:
            msgs = list(dict.fromkeys(_MESSAGES.get(e["type"], e["msg"]) for e in errs))
        first = errs[0]
        got = f" (got {_short(first['input'])})" if first.get("type") != "missing" and "input" in first else ""
        parts.append(f"field {field_path(loc)}: {' or '.join(msgs)}{got}")
    more = len(grouped) - limit
    if more > 0:
        parts.append(f"and {more} more problem(s)")
    return f"{where}: " + "; ".join(parts)


def validate(model: type[M], data: Any, where: str) -> M:
    """``model.model_validate(data)``, or ``ValueError`` with :func:`describe`'s message.

    A top-level ``"provenance"`` object (written with every fringe3d file,
    :mod:`fringe3d.utils.provenance`) is not part of any file model and is ignored."""
    try:
        return model.model_validate(without_provenance(data))
    except pydantic.ValidationError as e:
        raise ValueError(describe(e, where)) from None
