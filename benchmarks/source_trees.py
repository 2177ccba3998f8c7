"""One benchmark script's hidden child mode run in a fresh interpreter with a source tree first on
``PYTHONPATH``: how the A/B scripts (``ab_decode_sizes.py``, ``decode_digests.py``) put two
versions of the library side by side on one machine."""
from __future__ import annotations

import json
import os
import subprocess
import sys


def child_json(tree: str, script: str, args: list[str]):
    """Run ``python SCRIPT ARGS`` with the package folder ``tree`` (the folder holding
    ``fringe3d``) first on ``PYTHONPATH``; return the JSON on the last line of its output
    (``CalledProcessError`` with its output when the child fails)."""
    env = dict(os.environ, PYTHONPATH=os.path.abspath(tree))
    proc = subprocess.run([sys.executable, script, *args], env=env, capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])
