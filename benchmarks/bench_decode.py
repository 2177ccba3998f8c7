"""Benchmark: fringe3d decoding vs fringes, OpenCV structured_light and the unavoidable-work bound.

1280x1024 uint8 camera frames, one run of ``--repeat`` alternated rounds after a warm-up (every
case of a capture timed once per round, in rotating order; min / median / max reported):

(a) the 15-frame three-frequency set (9-step T=18 + 3-step T=21 + 3-step T=144) decoded to
    absolute phase: ``fringe3d.decode.decode`` (whole manifest-driven decoder: frame checks,
    fused heterodyne kernel, mask, texture, quality outputs) and the fused kernel alone
    (``unwrap.temporal.three_frequency_decode``); peer: ``fringes`` ``Fringes.decode``.
(b) 3-step: ``fringe3d.phase.psp.wrapped_phase`` (the kernel: phase + average + modulation) and
    ``decode()`` of the 3-step set; peers: OpenCV ``SinusoidalPattern.computePhaseMap`` (PSP)
    and ``fringes`` ``decode(unwrap=False)``.

Bound, in the same alternated rounds: the copy bound, ``np.copyto`` of the input frames into a
preallocated stack (the bytes any decoder must read). "copy + np.arctan2" (the copy plus one
float32 ``np.arctan2`` per output pixel) is a second, named reference. ``--threads N`` sets
numba's thread count (default: all cores). The wrap-error count of the scene (pixels whose
fringe order is wrong against the known ramp) is printed with (a).

Peers run in a separate interpreter (``--peer-python``, default ``$FRINGE3D_BENCH_PYTHON``,
else ``/tmp/benchvenv/bin/python`` if it exists, else this one) so that
``opencv-contrib-python-headless`` and ``fringes`` never touch the project's environment; a
peer that is missing is printed as "peer not installed". ``--json`` prints one object whose
``figures`` the summary table of ``run_all.py`` collects (``benchmarks/summary.py``).

Example: python benchmarks/bench_decode.py --repeat 10
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import alternated, figure, format_table, table_rows, timed_figures  # noqa: E402  (beside this script)

H, W = 1024, 1280


def make_frames():
    """uint8 frames of the 15-frame set and of a 3-step set, camera 1280x1024, known u_p."""
    from fringe3d.patterns import sets
    from fringe3d.patterns.synthetic import frames_from_coordinates
    ps15 = sets.three_frequency("v", width=912, height=570)
    ps3 = sets.phase_shift(18, 3, "v", width=912, height=570)
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    u_p = 5 + 0.7 * u + 3 * np.sin(2 * np.pi * v / H)
    vp = np.full_like(u_p, 300.0)
    rng = np.random.default_rng(0)
    f15 = frames_from_coordinates(ps15, u_p, vp, 30, 180, noise=1.0, rng=rng, dtype=np.uint8)
    f3 = frames_from_coordinates(ps3, u_p, vp, 30, 180, noise=1.0, rng=rng, dtype=np.uint8)
    return ps15, f15, ps3, f3, 2 * np.pi * u_p / 18


def bound_cases(frames: np.ndarray) -> dict:
    """The copy bound (``np.copyto`` of the input frames into a preallocated stack) and the
    "copy + arctan2" reference (the same copy plus one float32 ``np.arctan2`` per output pixel),
    as calls for :func:`summary.alternated`; the definitions of ``timing.bound_times``."""
    h, w = frames.shape[1:]
    rng = np.random.default_rng(1)
    y, x = rng.standard_normal((2, h, w)).astype(np.float32)
    out = np.empty((h, w), np.float32)
    dst = np.empty_like(frames)

    def copy_atan():
        np.copyto(dst, frames)
        np.arctan2(y, x, out=out)
    return {"bound": lambda: np.copyto(dst, frames), "copy_atan": copy_atan}


def ours(ps15, f15, ps3, f3, truth, rounds: int) -> dict:
    """Alternated rounds of fringe3d's decoders and the bounds, per capture; accuracy on the truth."""
    from fringe3d.decode import decode
    from fringe3d.phase.psp import wrapped_phase
    from fringe3d.unwrap.temporal import three_frequency_decode
    groups = [ps15.indices(group=g) for g in ps15.groups("v", "phase")]
    shifts = [[ps15.frames[i].shift for i in g] for g in groups]
    plan = ps15.plan("v")
    kernel = lambda: three_frequency_decode(f15, groups, shifts, plan.periods,  # noqa: E731
                                            w_range=tuple(plan.options["w_range"]), min_modulation=5.0,
                                            saturation_level=255)
    d = decode(f15, ps15)
    err = d.phase["v"] - truth
    sh3 = [f.shift for f in ps3.frames]
    wp = wrapped_phase(f3, sh3)
    err3 = np.angle(np.exp(1j * (wp.phase - truth)))
    a = alternated({**bound_cases(f15), "kernel": kernel, "decode": lambda: decode(f15, ps15)}, rounds)
    b = alternated({**bound_cases(f3), "kernel": lambda: wrapped_phase(f3, sh3), "decode": lambda: decode(f3, ps3)},
                   rounds)
    return {
        "a_seconds": a, "b_seconds": b,
        "a_phase_rms_rad": float(np.sqrt(np.nanmean(err ** 2))),
        "a_order_errors": int(np.sum(np.abs(err) > np.pi)),
        "b_phase_rms_rad": float(np.sqrt(np.mean(err3 ** 2))),
    }


ROLES = {"bound": "bound", "copy_atan": "reference", "kernel": "kernel", "decode": "ours"}
GROUP_A = f"decode, 15-frame three-frequency, {W}x{H}"
GROUP_B = f"decode, 3-step wrapped phase, {W}x{H}"


def figures(r: dict) -> tuple[list[dict], dict]:
    """The summary figures (``summary.figure`` dicts) and group notes of one run."""
    o, fr, cv = r["ours"], r["peers"]["fringes"], r["peers"]["opencv"]
    names_a = {"bound": "copy bound: np.copyto of the 15 frames", "copy_atan": "copy + np.arctan2 (float32)",
               "kernel": "fused three-frequency kernel", "decode": "decode() (whole decoder, every output)"}
    names_b = {"bound": "copy bound: np.copyto of the 3 frames", "copy_atan": "copy + np.arctan2 (float32)",
               "kernel": "wrapped_phase (3-step kernel)", "decode": "decode() of the 3-step set"}
    out = timed_figures(GROUP_A, o["a_seconds"], ROLES, names=names_a)
    out.append(_peer(GROUP_A, "fringes Fringes.decode", fr, "a"))
    out += timed_figures(GROUP_B, o["b_seconds"], ROLES, names=names_b)
    out.append(_peer(GROUP_B, "OpenCV structured_light computePhaseMap (PSP)", cv, "b"))
    out.append(_peer(GROUP_B, "fringes decode(unwrap=False)", fr, "b"))
    notes = {GROUP_A: {"scene": "synthetic ramp u_p = 5 + 0.7 u + 3 sin, noise 1 grey level",
                       "wrap_errors": o["a_order_errors"]},
             GROUP_B: {"scene": "the same ramp, 3 frames (wrapped phase: no order to get wrong)"}}
    return out, notes


def _peer(group: str, name: str, p: dict, case: str) -> dict:
    """A peer's figure (ms; its own process, its own alternation), or "not installed"."""
    if p.get("status") != "ok" or f"{case}_seconds" not in p:
        return figure(group, name, "peer", "ms", None, status="peer not installed")
    return figure(group, name, "peer", "ms", [1e3 * t for t in p[f"{case}_seconds"]], version=p.get("version"))


def peer_python(arg: str | None) -> str:
    if arg:
        return arg
    env = os.environ.get("FRINGE3D_BENCH_PYTHON")
    if env:
        return env
    if Path("/tmp/benchvenv/bin/python").exists():
        return "/tmp/benchvenv/bin/python"
    return sys.executable


def peers(f3: np.ndarray, repeat: int, python: str) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "frames3.npy"
        np.save(path, f3)
        try:
            out = subprocess.run([python, str(Path(__file__).with_name("peers.py")), str(path), str(repeat)],
                                 capture_output=True, text=True, timeout=1800)
        except (OSError, subprocess.TimeoutExpired) as e:
            return {"fringes": {"status": "not installed", "error": str(e)},
                    "opencv": {"status": "not installed", "error": str(e)}}
    try:
        return json.loads(out.stdout.strip().splitlines()[-1])
    except (json.JSONDecodeError, IndexError):
        err = (out.stderr or "no output").strip().splitlines()[-1:]
        return {"fringes": {"status": "not installed", "error": err},
                "opencv": {"status": "not installed", "error": err}}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=10, help="alternated rounds (min / median / max reported)")
    ap.add_argument("--peer-python", default=None, help="interpreter with fringes / opencv-contrib installed")
    ap.add_argument("--no-peers", action="store_true", help="time fringe3d and the bound only")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--threads", type=int, default=None, help="numba threads (default: all cores)")
    args = ap.parse_args(argv)
    import fringe3d.phase._kernels  # noqa: F401  (sets OMP_WAIT_POLICY before numba starts its threads)
    import numba
    if args.threads:
        numba.set_num_threads(args.threads)
    load_start = round(os.getloadavg()[0], 1)
    ps15, f15, ps3, f3, truth = make_frames()
    r: dict = {"benchmark": "decode", "repeat": args.repeat, "size": [W, H]}
    r["ours"] = ours(ps15, f15, ps3, f3, truth, args.repeat)
    r["numba_threads"] = numba.get_num_threads()
    r["load_average"] = f"{load_start} -> {round(os.getloadavg()[0], 1)}"
    r["peers"] = ({"fringes": {"status": "not installed"}, "opencv": {"status": "not installed"}} if args.no_peers
                  else peers(f3, args.repeat, peer_python(args.peer_python)))
    r["figures"], r["groups"] = figures(r)
    if args.json:
        print(json.dumps(r, indent=1))
        return r
    o, fr = r["ours"], r["peers"]["fringes"]
    print(format_table(table_rows(r["figures"]), r["groups"],
                       f"decode benchmark, {W}x{H} uint8 frames, {args.repeat} alternated rounds, {os.cpu_count()} "
                       f"cores, numba threads {r['numba_threads']}, load average {r['load_average']}"))
    print(f"accuracy: (a) phase RMS {o['a_phase_rms_rad']:.4f} rad, {o['a_order_errors']} order errors; "
          f"(b) phase RMS {o['b_phase_rms_rad']:.4f} rad (noise 1 grey level)")
    if fr.get("status") == "ok":
        print(f"fringes {fr.get('version')}: first call (JIT) {fr['a_first_call_s']:.1f} s, "
              f"its coordinate RMS {fr['a_coordinate_rms_px']:.3f} px on its own frames")
    return r


if __name__ == "__main__":
    main()
