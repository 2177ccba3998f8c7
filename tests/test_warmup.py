"""``fringe3d warmup`` compiles what the first real frame needs: afterwards a fresh process
reconstructs a capture of another size with every numba kernel loaded from the on-disk cache."""
from __future__ import annotations

import json
import subprocess
import sys

from typer.testing import CliRunner

from fringe3d.cli import app

FIRST_FRAME = r"""
import sys, warnings
import numba.core.registry  # noqa: F401
from fringe3d.decode import DecodeOptions
from fringe3d.io.capture import read_capture
from fringe3d.optics import Rig
from fringe3d.reconstruct.frame import FrameReconstructor, reconstruction_plans
warnings.simplefilter("ignore")
cap = read_capture(sys.argv[1])
rec = FrameReconstructor(reconstruction_plans(cap.patterns, "geometric"), Rig.load(sys.argv[1] + "/rig.json"),
                         DecodeOptions(z_min=340.0))
rec.reconstruct(cap.frames[:3])
from numba.core.dispatcher import Dispatcher
import gc
misses = {d.py_func.__qualname__: sum(d.stats.cache_misses.values())
          for d in gc.get_objects() if isinstance(d, Dispatcher) and d.py_func.__module__.startswith("fringe3d")}
print({k: v for k, v in misses.items() if v})
"""


def test_warmup_runs_both_paths_and_reports_them():
    result = CliRunner().invoke(app, ["warmup", "--json"])
    assert result.exit_code == 0, result.output
    paths = [r["path"] for r in json.loads(result.output)["paths"]]
    assert paths == ["decode + triangulate", "fused 3-step + geometric"]


def test_first_fused_frame_after_warmup_compiles_nothing(tmp_path):
    from fringe3d.patterns import sets
    from fringe3d.sim import simulate_capture

    assert CliRunner().invoke(app, ["warmup", "-q"]).exit_code == 0
    cap = tmp_path / "cap"  # another period and scene seed than the warm-up
    simulate_capture(cap, preset="tiny", scene="sphere", patterns=sets.phase_shift(48, 3, "v", width=256, height=200),
                     seed=3, progress=False)
    out = subprocess.run([sys.executable, "-c", FIRST_FRAME, str(cap)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "{}", f"kernels compiled on the first frame after warmup: {out.stdout}"
