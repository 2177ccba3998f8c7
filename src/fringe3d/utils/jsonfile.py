"""JSON files: one reader (errors that say which file and what was expected) and one writer."""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Mapping

from fringe3d.utils.atomic import atomic_write_text
from fringe3d.utils.provenance import PROVENANCE_KEY, provenance


#: Largest JSON file fringe3d reads (bytes) and deepest nesting it accepts.
MAX_JSON_BYTES = 64 << 20
MAX_JSON_DEPTH = 32


def _depth(obj, level: int = 1) -> int:
    """Nesting depth of parsed JSON, iteratively (no recursion limit)."""
    deepest, stack = 0, [(obj, level)]
    while stack:
        o, lv = stack.pop()
        deepest = max(deepest, lv)
        if lv > MAX_JSON_DEPTH:
            break
        if isinstance(o, dict):
            stack.extend((v, lv + 1) for v in o.values())
        elif isinstance(o, list):
            stack.extend((v, lv + 1) for v in o)
    return deepest


def read_json(path: str | os.PathLike, what: str = "JSON file", require_object: bool = True):
    """Parse the JSON file ``path``.

    Raises ``FileNotFoundError`` ("no {what} at {path}") when it is missing and ``ValueError``
    when it is not valid JSON or (``require_object``) not a JSON object.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise FileNotFoundError(f"no {what} at {path}") from None
    if size > MAX_JSON_BYTES:
        raise ValueError(f"{what} {path} is {size} bytes; fringe3d reads JSON files of at most {MAX_JSON_BYTES}")
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise FileNotFoundError(f"no {what} at {path}") from None
    except IsADirectoryError:
        raise ValueError(f"{path} is a folder; expected a {what}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{what} {path} is not a text file") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"{what} {path} is not valid JSON: {e}") from None
    except RecursionError:
        raise ValueError(f"{what} {path} is nested too deeply (more than Python's recursion limit); "
                         "expected a flat fringe3d JSON file") from None
    depth = _depth(data)
    if depth > MAX_JSON_DEPTH:
        raise ValueError(f"{what} {path} is nested {depth} levels deep; fringe3d files nest at most {MAX_JSON_DEPTH}")
    if require_object and not isinstance(data, dict):
        raise ValueError(f"{what} {path} must hold a JSON object, got {type(data).__name__}")
    return data


def read_format_json(path: str | os.PathLike, what: str, format_name: str) -> dict:
    """Parse a fringe3d JSON document whose ``format`` field must be ``format_name``.

    Parameters
    ----------
    path : path-like
        The file.
    what : str
        What the file is, for the messages ("poses file", "turntable axis file").
    format_name : str
        The value its ``format`` field must hold.

    Returns
    -------
    dict
        The document.

    Raises
    ------
    ValueError
        The file does not exist, is not valid JSON (:func:`read_json`), or its ``format`` differs;
        each message names the file and the field.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{what} {path} does not exist")
    doc = read_json(path, what)
    if doc.get("format") != format_name:
        raise ValueError(f"{what} {path}: field 'format' must be {format_name!r}")
    return doc


def to_jsonable(obj):
    """Convert numpy scalars/arrays and non-finite floats into JSON-friendly values."""
    import numpy as np  # here, not at the top: the command line's start (``--help``) needs no numpy

    return _jsonable(obj, np)


def _jsonable(obj, np):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v, np) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v, np) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist(), np)
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    return obj


def write_json(path: str | os.PathLike, obj, allow_nan: bool = True, units: Mapping[str, str] | None = None) -> None:
    """Write ``obj`` as indented JSON to ``path`` atomically (temporary name, then rename).

    NumPy scalars and arrays become JSON numbers and lists and non-finite floats become
    ``null`` (:func:`to_jsonable`); with ``allow_nan=False`` the object is written as given and
    a non-finite float raises ``ValueError`` instead. With ``units`` (quantity or kind -> unit)
    the object (a dict) gets a ``"provenance"`` entry: fringe3d version, time, command line and
    the units (:func:`fringe3d.utils.provenance.provenance`). Every file a command writes passes them.
    """
    if units is not None:
        if not isinstance(obj, dict):
            raise TypeError(f"write_json: units need a JSON object to hold them, got {type(obj).__name__}")
        obj = {**obj, PROVENANCE_KEY: provenance(units)}
    data = to_jsonable(obj) if allow_nan else obj
    atomic_write_text(path, json.dumps(data, indent=1, allow_nan=allow_nan))
