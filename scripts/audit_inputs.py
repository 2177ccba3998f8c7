"""Re-run the reliability audit's categories against the CLI and count what went wrong.

Usage: .venv/bin/python scripts/audit_inputs.py [--seed 0] [--per-category 40] [--json]

Every attempt runs one ``fringe3d`` command in this process (``fringe3d.cli.main``) on a damaged copy
of a simulated capture, or a subprocess where signals or concurrency are the point. For each it checks:

- writes outside the output folder (a snapshot of the whole work folder minus the output);
- tracebacks (an exception escaping ``main``, or "Traceback" on stderr) and exit code 1 for user input;
- exit 0 on an invalid input (every damaged input here is invalid, except where marked "valid");
- files lost (the input copy changed);
- interrupted or failed runs presented as complete (``fringe3d.json`` says complete, or a reader accepts it).

The counts are printed per category; a non-zero count in any "bad" column exits 1.
"""
from __future__ import annotations

import argparse
import contextlib
import copy
import io
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fringe3d.cli import main
from fringe3d.io.capture import read_capture

import fringe3d  # noqa: E402

ROOT = Path(fringe3d.__file__).resolve().parents[2]  # the checkout whose fringe3d is audited (subprocesses too)
HOSTILE_VALUES = [None, True, False, 0, -1, 1e9, -1e300, float("nan"), float("inf"), "", "abc", "../../x",
                  "/etc/passwd", [], [1, 2], {}, {"a": 1}, [[1, 2], [3]], 2 ** 70]


def snapshot(root: Path, skip: Path | None = None) -> dict:
    out = {}
    for p in sorted(root.rglob("*")):
        if skip is not None and (p == skip or skip in p.parents):
            continue
        if p.is_file() and not p.is_symlink():
            out[p.relative_to(root).as_posix()] = p.read_bytes()
    return out


def run_cli(argv: list[str]) -> tuple[int | None, str]:
    err = io.StringIO()
    from fringe3d.utils import console
    old = console.err_console.file
    console.err_console.file = err
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(argv)
    except BaseException as e:  # an escaped exception is a traceback for the user
        return None, f"{type(e).__name__}: {e}"
    finally:
        console.err_console.file = old
    return code, err.getvalue()


def leaves(doc, prefix=()):
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from leaves(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from leaves(v, prefix + (i,))


def replaced(doc, path, value):
    doc = copy.deepcopy(doc)
    if not path:
        return value
    node = doc
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value
    return doc


class Audit:
    def __init__(self, work: Path, seed: int, n: int):
        self.work, self.rng, self.n = work, random.Random(seed), n
        self.base = work / "base"
        assert main(["simulate", "-o", str(self.base), "--preset", "tiny", "--scene", "plane", "-q"]) == 0
        np.save(self.base / "points.npy", np.zeros((8, 8, 3), np.float32))
        self.counts: dict[str, dict[str, int]] = {}

    def count(self, category: str, key: str) -> None:
        c = self.counts.setdefault(category, {"attempts": 0, "outside_writes": 0, "files_lost": 0,
                                              "tracebacks": 0, "exit0_on_invalid": 0, "presented_complete": 0})
        c[key] += 1

    def attempt(self, category: str, damage, argv: list[str], valid: bool = False) -> None:
        case = Path(tempfile.mkdtemp(dir=self.work))
        cap = case / "cap"
        shutil.copytree(self.base, cap)
        damage(cap)
        out = case / "out"
        before = snapshot(case, skip=out)
        code, err = run_cli([a.format(cap=cap, out=out) for a in argv])
        self.count(category, "attempts")
        after = snapshot(case, skip=out)
        if set(after) - set(before):
            self.count(category, "outside_writes")
        if any(k in after and after[k] != v for k, v in before.items()) or set(before) - set(after):
            self.count(category, "files_lost")
        if code is None or code == 1 or "Traceback" in err:
            self.count(category, "tracebacks")
            print(f"  traceback in {category}: {' '.join(argv)}: {err.strip()[-300:]}", file=sys.stderr)
        if code == 0 and not valid:
            self.count(category, "exit0_on_invalid")
            print(f"  exit 0 on invalid input in {category}: {' '.join(argv)}", file=sys.stderr)
        shutil.rmtree(case, ignore_errors=True)

    # -- categories -----------------------------------------------------------------------
    def json_fields(self, category: str, name: str, argv: list[str]) -> None:
        doc = json.loads((self.base / name).read_text())
        paths = list(leaves(doc))
        for _ in range(self.n):
            path, value = self.rng.choice(paths), self.rng.choice(HOSTILE_VALUES)
            bad = replaced(doc, path, value)
            if bad == doc:
                continue

            def damage(cap, bad=bad):
                (cap / name).write_text(json.dumps(bad))
            self.attempt(category, damage, argv, valid=self._still_valid(name, bad))

    def _still_valid(self, name: str, doc) -> bool:
        """Some replacements leave a valid file (e.g. a name string); those may exit 0."""
        tmp = Path(tempfile.mkdtemp(dir=self.work))
        shutil.copytree(self.base, tmp / "c")
        (tmp / "c" / name).write_text(json.dumps(doc))
        try:
            if name == "rig.json":
                from fringe3d.optics import Rig
                Rig.load(tmp / "c" / name)
            else:
                read_capture(tmp / "c")
            return True
        except Exception:  # refused (or, on old code, crashed): not a valid input
            return False
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    def frames(self) -> None:
        files = sorted((self.base / "frames").glob("*.png"))
        damages = [lambda f: f.write_bytes(b""), lambda f: f.write_bytes(f.read_bytes()[:40]),
                   lambda f: f.write_bytes(b"not an image"), lambda f: f.unlink(),
                   lambda f: f.rename(f.with_name("x" + f.name))]
        for _ in range(self.n):
            i, how = self.rng.randrange(len(files)), self.rng.choice(damages)

            def damage(cap, i=i, how=how):
                how(cap / "frames" / files[i].name)
            self.attempt("malformed frames", damage, ["decode", "{cap}", "-o", "{out}"])

    def scenes(self) -> None:
        doc = {"objects": [{"type": "plane", "point": [0, 0, 300], "normal": [0, 0, -1]},
                           {"type": "sphere", "center": [0, 0, 280], "radius": 10}]}
        paths = list(leaves(doc))
        for _ in range(self.n):
            bad = replaced(doc, self.rng.choice(paths), self.rng.choice(HOSTILE_VALUES))

            def damage(cap, bad=bad):
                (cap / "scene.json").write_text(json.dumps(bad))
            self.attempt("scene files", damage, ["simulate", "--scene", "{cap}/scene.json", "-o", "{out}", "-q"],
                         valid=True)  # a replaced value may still be a valid scene: exit 0 allowed here

    def options(self) -> None:
        table = [("decode", "--min-modulation"), ("decode", "--z-min"), ("reconstruct", "--z-min"),
                 ("reconstruct", "--min-modulation"), ("simulate", "--noise"), ("simulate", "--defocus"),
                 ("patterns", "--width"), ("calibrate", "--cols"), ("evaluate", "--exclude")]
        values = ["nan", "inf", "-inf", "-1", "1e9", "0", "abc", "", "1e400", "-0"]
        argv_of = {"decode": ["decode", "{cap}", "-o", "{out}"],
                   "reconstruct": ["reconstruct", "{cap}", "-c", "{cap}/rig.json", "-o", "{out}"],
                   "simulate": ["simulate", "-o", "{out}", "-q"],
                   "patterns": ["patterns", "-o", "{out}", "-q"],
                   "calibrate": ["calibrate", "{cap}", "-o", "{out}.json", "-q"],
                   "evaluate": ["evaluate", "{cap}/points.npy", "--plane"]}
        for _ in range(self.n):
            (cmd, opt), v = self.rng.choice(table), self.rng.choice(values)
            self.attempt("options", lambda cap: None, argv_of[cmd] + [opt, v], valid=True)

    def output_safety(self) -> None:
        cases = [
            (lambda cap: None, ["decode", "{cap}", "-o", "{cap}"]),
            (lambda cap: None, ["decode", "{cap}", "-o", "{cap}/frames", "--overwrite"]),
            (lambda cap: None, ["simulate", "-o", "{cap}", "-q"]),
            (lambda cap: None, ["patterns", "-o", "{cap}/frames", "-q"]),
            (lambda cap: os.symlink(cap / "frames", cap.parent / "out"), ["patterns", "-o", "{out}", "-q",
                                                                          "--overwrite"]),
            (lambda cap: os.symlink(cap / "rig.json", cap.parent / "out.json"),
             ["calibrate", "--import-opencv", "{cap}/rig.json", "-o", "{out}.json", "--overwrite"]),
            (lambda cap: (cap.parent / "out").mkdir() or (cap.parent / "out" / "keep.txt").write_text("mine"),
             ["decode", "{cap}", "-o", "{out}"]),
            (lambda cap: (cap / "rig.json").write_text((cap / "rig.json").read_text()),
             ["calibrate", "--import-opencv", "{cap}/rig.json", "-o", "{cap}/rig.json"]),
        ]
        for _ in range(max(1, self.n // len(cases))):
            for damage, argv in cases:
                self.attempt("output safety", damage, argv)

    def interruption(self) -> None:
        for k in range(max(2, self.n // 10)):
            case = Path(tempfile.mkdtemp(dir=self.work))
            out = case / "long"
            env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
            proc = subprocess.Popen([sys.executable, "-m", "fringe3d", "simulate", "-o", str(out), "--preset",
                                     "tiny", "--scene", "wing", "--frames", "310"], env=env,
                                    stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
            time.sleep(0.5 + 0.4 * k)
            sig = signal.SIGINT if k % 2 == 0 else signal.SIGKILL
            proc.send_signal(sig)
            _, err = proc.communicate(timeout=300)
            self.count("interruption", "attempts")
            complete_marker = (out / "fringe3d.json").exists() and json.loads(
                (out / "fringe3d.json").read_text()).get("complete") is True
            if proc.returncode == 0:
                continue  # finished before the signal: a complete, valid output
            if complete_marker:
                self.count("interruption", "presented_complete")
            if "Traceback" in (err or ""):
                self.count("interruption", "tracebacks")
                print(f"  traceback after {sig.name}: {err.strip()[-400:]}", file=sys.stderr)
            with contextlib.suppress(ValueError, FileNotFoundError):
                read_capture(out)
                self.count("interruption", "presented_complete")
            shutil.rmtree(case, ignore_errors=True)

    def concurrency(self) -> None:
        for _ in range(max(2, self.n // 10)):
            case = Path(tempfile.mkdtemp(dir=self.work))
            env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
            argv = [sys.executable, "-m", "fringe3d", "simulate", "-o", str(case / "out"), "--preset", "tiny",
                    "--scene", "plane", "-q"]
            procs = [subprocess.Popen(argv + ["--seed", str(s)], env=env, stderr=subprocess.PIPE,
                                      stdout=subprocess.DEVNULL, text=True) for s in (1, 2)]
            results = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
            self.count("concurrency", "attempts")
            if sum(code == 0 for code, _ in results) != 1:
                self.count("concurrency", "presented_complete")  # both "won", or none did
            if any("Traceback" in e for _, e in results):
                self.count("concurrency", "tracebacks")
            winner = [s for s, (code, _) in zip((1, 2), results) if code == 0]
            try:
                cap = read_capture(case / "out")
            except (ValueError, FileNotFoundError) as e:
                if winner:  # a run said it succeeded, but its output is unreadable
                    self.count("concurrency", "files_lost")
                    print(f"  concurrency: {e}; exit codes {[c for c, _ in results]}", file=sys.stderr)
                continue
            ref = case / "ref"
            subprocess.run(argv[:5] + [str(ref)] + argv[6:] + ["--seed", str(winner[0])], env=env, check=True)
            if not np.array_equal(cap.frames, read_capture(ref).frames):
                self.count("concurrency", "presented_complete")  # mixed frames
            shutil.rmtree(case, ignore_errors=True)


def main_(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--per-category", type=int, default=40)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        a = Audit(Path(tmp), args.seed, args.per_category)
        a.frames()
        a.json_fields("hostile manifests", "manifest.json", ["decode", "{cap}", "-o", "{out}"])
        a.json_fields("capture.json", "capture.json", ["decode", "{cap}", "-o", "{out}"])
        a.json_fields("rigs", "rig.json", ["reconstruct", "{cap}", "-c", "{cap}/rig.json", "-o", "{out}"])
        a.scenes()
        a.options()
        a.output_safety()
        a.interruption()
        a.concurrency()
    if args.json:
        print(json.dumps(a.counts, indent=1))
    else:
        cols = ["attempts", "outside_writes", "files_lost", "tracebacks", "exit0_on_invalid", "presented_complete"]
        print(f"{'category':20s} " + " ".join(f"{c:>18s}" for c in cols))
        for cat, c in a.counts.items():
            print(f"{cat:20s} " + " ".join(f"{c[k]:>18d}" for k in cols))
        total = {k: sum(c[k] for c in a.counts.values()) for k in cols}
        print(f"{'total':20s} " + " ".join(f"{total[k]:>18d}" for k in cols))
    bad = sum(c[k] for c in a.counts.values() for k in c if k != "attempts")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main_())
