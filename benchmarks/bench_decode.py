"""Benchmark: fringe3d decoding vs fringes, OpenCV structured_light and the unavoidable-work bound.

1280x1024 uint8 camera frames, one run, median of ``--repeat`` timed calls after a warm-up:

(a) the 15-frame three-frequency set (9-step T=18 + 3-step T=21 + 3-step T=144) decoded to
    absolute phase: ``fringe3d.decode.decode`` (whole manifest-driven decoder: frame checks,
    fused heterodyne kernel, mask, texture) and the fused kernel alone
    (``unwrap.temporal.three_frequency_decode``); peer: ``fringes`` ``Fringes.decode``.
(b) 3-step wrapped phase alone: ``fringe3d.phase.psp.wrapped_phase`` (phase + average +
    modulation); peers: OpenCV ``SinusoidalPattern.computePhaseMap`` (PSP) and ``fringes``
    ``decode(unwrap=False)``.

Bound (same run): copying the input bytes (``np.copyto`` into a preallocated stack) plus NumPy's
vectorised ``np.arctan2`` over the output pixels (float32 in and out) - the work any decoder must
do; the same function (``benchmarks/timing.py``, :func:`bound_times`) as ``python
benchmarks/timing.py``. ``--threads N`` sets numba's thread count (default: all cores).

Peers run in a separate interpreter (``--peer-python``, default ``$FRINGE3D_BENCH_PYTHON``,
else ``/tmp/benchvenv/bin/python`` if it exists, else this one) so that
``opencv-contrib-python-headless`` and ``fringes`` never touch the project's environment; a
peer that is missing is printed as "not installed".

Example: python benchmarks/bench_decode.py --repeat 10
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

H, W = 1024, 1280


BEST: dict = {}  # id of the last timed call -> best time, filled by median_time


def median_time(fn, repeat: int, key: str | None = None) -> float:
    """Median wall time of ``repeat`` calls after one warm-up; the best goes to ``BEST[key]``."""
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    if key:
        BEST[key] = float(np.min(ts))
    return float(np.median(ts))


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


def bound_time(frames: np.ndarray, repeat: int) -> float:
    """Copy of the input bytes + np.arctan2 over the output pixels (float32 in, float32 out),
    the definition shared with ``python benchmarks/timing.py``
    (``timing.bound_times``); median returned, best kept in ``BEST``."""
    from timing import bound_times  # benchmarks/timing.py, beside this script
    b = bound_times(frames, repeat)
    BEST[f"bound{len(frames)}"] = b["best"]
    return b["median"]


def ours(ps15, f15, ps3, f3, truth, repeat: int) -> dict:
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
    return {
        "a_decode_s": median_time(lambda: decode(f15, ps15), repeat, "a_decode"),
        "a_kernel_s": median_time(kernel, repeat, "a_kernel"),
        "a_phase_rms_rad": float(np.sqrt(np.nanmean(err ** 2))),
        "a_order_errors": int(np.sum(np.abs(err) > np.pi)),
        "b_s": median_time(lambda: wrapped_phase(f3, sh3), repeat, "b"),
        "b_decode_s": median_time(lambda: decode(f3, ps3), repeat, "b_decode"),
        "b_phase_rms_rad": float(np.sqrt(np.mean(err3 ** 2))),
    }


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


def fmt_ms(s):
    return "not installed" if s is None else f"{1000 * s:9.1f} ms"


def table(r: dict) -> str:
    o, fr, cv, bnd = r["ours"], r["peers"]["fringes"], r["peers"]["opencv"], r["bound_s"]
    fa = fr.get("a_s") if fr.get("status") == "ok" else None
    fb = fr.get("b_s") if fr.get("status") == "ok" else None
    cb = cv.get("b_s") if cv.get("status") == "ok" else None
    lines = [f"decode benchmark, {W}x{H} uint8 frames, median of {r['repeat']} runs, {os.cpu_count()} cores, "
             f"numba threads {r.get('numba_threads')}, load average {r.get('load_average')}",
             f"{'task':<46}{'time':>14}{'vs bound':>10}{'peer/ours':>11}"]

    def row(name, t, ours_t=None):
        vb = "" if t is None else f"{t / bnd['a' if name.startswith('(a)') else 'b']:9.1f}x"
        pr = "" if t is None or ours_t is None else f"{t / ours_t:10.1f}x"
        lines.append(f"{name:<46}{fmt_ms(t):>14}{vb:>10}{pr:>11}")

    lines.append(f"{'(a) bound: copy 15 frames + arctan2':<46}{fmt_ms(bnd['a']):>14}")
    row("(a) fringe3d decode() (whole decoder)", o["a_decode_s"])
    row("(a) fringe3d fused three-frequency kernel", o["a_kernel_s"])
    row("(a) fringes Fringes.decode", fa, o["a_decode_s"])  # peer/ours vs the whole decoder
    lines.append(f"{'(a) OpenCV structured_light':<46}{'n/a (no multi-frequency decoder)':>35}")
    lines.append(f"{'(b) bound: copy 3 frames + arctan2':<46}{fmt_ms(bnd['b']):>14}")
    row("(b) fringe3d wrapped_phase (3-step)", o["b_s"])
    row("(b) fringe3d decode() of the 3-step set", o["b_decode_s"])
    fastest_b = min(o["b_s"], o["b_decode_s"])
    row("(b) OpenCV computePhaseMap (PSP)", cb, fastest_b)
    row("(b) fringes decode(unwrap=False)", fb, fastest_b)
    b = r.get("best_s", {})
    if b:
        lines.append("best of runs (ms): " + ", ".join(f"{k} {1000 * v:.1f}" for k, v in b.items()))
    lines.append(f"accuracy: (a) phase RMS {o['a_phase_rms_rad']:.4f} rad, {o['a_order_errors']} order errors; "
                 f"(b) phase RMS {o['b_phase_rms_rad']:.4f} rad (noise 1 grey level)")
    if fr.get("status") == "ok":
        lines.append(f"fringes {fr.get('version')}: first call (JIT) {fr['a_first_call_s']:.1f} s, "
                     f"its coordinate RMS {fr['a_coordinate_rms_px']:.3f} px on its own frames")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=10, help="timed repetitions (median reported)")
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
    r = {"repeat": args.repeat, "size": [W, H]}
    r["ours"] = ours(ps15, f15, ps3, f3, truth, args.repeat)
    r["bound_s"] = {"a": bound_time(f15, args.repeat), "b": bound_time(f3, args.repeat)}
    r["best_s"] = {"(a) bound": BEST["bound15"], "(a) decode": BEST["a_decode"], "(a) kernel": BEST["a_kernel"],
                   "(b) bound": BEST["bound3"], "(b) wrapped_phase": BEST["b"],
                   "(b) decode": BEST["b_decode"]}
    r["numba_threads"] = numba.get_num_threads()
    r["load_average"] = f"{load_start} -> {round(os.getloadavg()[0], 1)}"
    r["peers"] = ({"fringes": {"status": "not installed"}, "opencv": {"status": "not installed"}} if args.no_peers
                  else peers(f3, args.repeat, peer_python(args.peer_python)))
    print(json.dumps(r, indent=1) if args.json else table(r))
    return r


if __name__ == "__main__":
    main()
