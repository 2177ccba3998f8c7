"""Runs a worker script of this folder under numba's CUDA simulator in its own process (the
simulator must be chosen before numba.cuda is first imported) and loads the arrays it saved."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent


def run_simulated(worker: str, out_dir: Path, timeout: float) -> dict:
    """``{name: array}`` of the ``.npz`` that ``tests/<worker>`` writes when run with numba's CUDA
    simulator and this checkout's ``src`` first on the path; fails with the worker's stderr."""
    out = out_dir / "results.npz"
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    env["PYTHONPATH"] = str(HERE.parent / "src") + os.pathsep + env.get("PYTHONPATH", "")
    p = subprocess.run([sys.executable, str(HERE / worker), str(out)], env=env, capture_output=True, text=True,
                       timeout=timeout, cwd=HERE)
    assert p.returncode == 0, p.stderr[-3000:]
    return dict(np.load(out))
