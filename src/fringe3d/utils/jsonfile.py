"""Reading JSON files with errors that say which file and what was expected."""
from __future__ import annotations

import json
import os
from pathlib import Path


def read_json(path: str | os.PathLike, what: str = "JSON file", require_object: bool = True):
    """Parse the JSON file ``path``.

    Raises ``FileNotFoundError`` ("no {what} at {path}") when it is missing and ``ValueError``
    when it is not valid JSON or (``require_object``) not a JSON object.
    """
    path = Path(path)
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
    if require_object and not isinstance(data, dict):
        raise ValueError(f"{what} {path} must hold a JSON object, got {type(data).__name__}")
    return data
