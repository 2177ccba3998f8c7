"""Per command: a disk-full error or a Ctrl-C at the 3rd file written, what the output folder is left
as, what the message says, and whether re-running the same command succeeds; then ``simulate``
killed (SIGKILL) half way and resumed, compared byte for byte with an uninterrupted run.

Usage: .venv/bin/python scripts/audit_interruptions.py [--skip-demo]

Prints a markdown table. Every failed or interrupted run must leave its output either removed
("removed") or kept and resumable ("kept/resume"), and the rerun must exit 0 with a complete set.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fringe3d.cli import main
from fringe3d.utils import console

_replace = os.replace


def _faulty(kind: str, at: int = 3):
    calls = [0]

    def replace(src, dst):
        calls[0] += 1
        if calls[0] == at and kind == "disk full":
            raise OSError(28, "No space left on device")
        if calls[0] == at:
            os.kill(os.getpid(), signal.SIGINT)  # a real Ctrl-C: the CLI's handler raises it in the main thread
        _replace(src, dst)
    return replace


def _run(argv: list[str]) -> tuple[int, str]:
    buf, old = io.StringIO(), console.err_console.file
    console.err_console.file = buf
    try:
        with contextlib.redirect_stderr(buf):
            return main(argv), " ".join(buf.getvalue().split())
    finally:
        console.err_console.file = old


def _state(out: Path) -> str:
    if not out.exists():
        return "absent"
    marker = out / "fringe3d.json"
    if not marker.exists():
        return "exists without a marker"
    d = json.loads(marker.read_text())
    return "complete" if d.get("complete") else "incomplete" + (" (resumable)" if d.get("resumable") else "")


def _said(msg: str) -> str:
    if "removed" in msg:
        return "removed"
    if "resume it" in msg:
        return "kept/resume"
    return msg[-80:]


def faults(commands: dict) -> bool:
    ok = True
    print("| command | fault | rc | message says | output left | rerun rc | rerun leaves |")
    print("|---|---|---|---|---|---|---|")
    for name, make in commands.items():
        for kind in ("disk full", "Ctrl-C"):
            work = Path(tempfile.mkdtemp(prefix="fringe3d-interrupt-"))
            argv = make(work / "out")
            os.replace = _faulty(kind)
            try:
                rc, msg = _run(argv)
            finally:
                os.replace = _replace
            left = _state(work / "out")
            rc2, msg2 = _run(argv)
            after = _state(work / "out")
            ok &= rc2 == 0 and after == "complete" and _said(msg) in ("removed", "kept/resume")
            print(f"| {name} | {kind} | {rc} | {_said(msg)} | {left} | {rc2} | {after} {msg2[-80:] if rc2 else ''} |",
                  flush=True)
            shutil.rmtree(work, ignore_errors=True)
    return ok


def _bodies(folder: Path) -> dict:
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.name != "fringe3d.json":
            data = p.read_bytes()
            if p.suffix == ".json":
                d = json.loads(data)
                d.pop("provenance", None)
                data = json.dumps(d, sort_keys=True).encode()
            out[p.relative_to(folder).as_posix()] = data
    return out


def killed_simulate(work: Path, frames: int = 62) -> bool:
    args = ["--preset", "tiny", "--scene", "wing", "--frames", str(frames), "--noise", "0.01", "--seed", "7", "-q"]
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    cli = [sys.executable, "-m", "fringe3d", "simulate"]
    subprocess.run(cli + ["-o", str(work / "whole")] + args, env=env, check=True)
    proc = subprocess.Popen(cli + ["-o", str(work / "part")] + args, env=env)
    while len(list((work / "part" / "frames").glob("[0-9]*.png"))) < frames // 2:
        time.sleep(0.02)
    proc.kill()
    proc.wait()
    n = len(list((work / "part" / "frames").glob("[0-9]*.png")))
    rerun = subprocess.run(cli + ["-o", str(work / "part")] + args, env=env, capture_output=True, text=True)
    whole, part = _bodies(work / "whole"), _bodies(work / "part")
    same = whole.keys() == part.keys() and all(whole[k] == part[k] for k in whole)
    print(f"\nsimulate SIGKILLed with {n} of {frames} frames written; rerun rc {rerun.returncode} "
          f"({' '.join(rerun.stderr.split())[:160]}); {len(whole)} files compared (JSON without provenance): "
          + ("bit-identical" if same else "DIFFERENT"))
    return rerun.returncode == 0 and same


def main_(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-demo", action="store_true")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="fringe3d-interrupt-") as tmp:
        cap, cap2 = Path(tmp) / "cap", Path(tmp) / "cap2"
        assert main(["simulate", "-o", str(cap), "--preset", "tiny", "--scene", "plane", "-q"]) == 0
        assert main(["simulate", "-o", str(cap2), "--preset", "tiny", "--scene", "plane", "--frames", "62", "-q"]) == 0
        commands = {
            "patterns": lambda out: ["patterns", "-o", str(out), "-q"],
            "simulate": lambda out: ["simulate", "--scene", "plane", "-o", str(out), "-q"],
            "import": lambda out: ["import", str(cap / "frames"), "--manifest", str(cap / "manifest.json"), "-o",
                                   str(out), "-q"],
            "decode": lambda out: ["decode", str(cap), "-o", str(out), "-q"],
            "decode (2 cycles)": lambda out: ["decode", str(cap2), "-o", str(out), "-q"],
            "reconstruct": lambda out: ["reconstruct", str(cap), "-c", str(cap / "rig.json"), "-o", str(out), "-q"],
            "reconstruct (2 cycles)": lambda out: ["reconstruct", str(cap2), "-c", str(cap2 / "rig.json"), "-o",
                                                   str(out), "-q"],
        }
        if not args.skip_demo:
            commands["demo --profile tiny"] = lambda out: ["demo", "--profile", "tiny", "-o", str(out), "-q"]
        ok = faults(commands)
        ok &= killed_simulate(Path(tmp))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main_())
