"""Are two source trees' decodes the same bytes? One digest of every output of ``decode()`` per scene.

Each tree runs in a fresh interpreter with its ``src/`` first on ``PYTHONPATH`` and decodes the
same scenes: ``bench_decode.py``'s ramp scene (15-frame three-frequency set and 3-step set) at
several sizes, and at 240 x 300 a clipped, a dark, a uint16, a float32 and a gamma 2.2 capture
of the 15-frame set (the last also with ``compensate="harmonic"`` and ``"response"``, and
without the edge mask), the two-direction calibration set, and 4- and 9-step, Gray-code,
hierarchical and 3-step three-frequency sets (the last also with ``compensate="disagreement"``).
The digest hashes the bytes, dtype and shape of every array of the :class:`Decoded` (phase,
mask, quality, phase sigma, wrapped phase, modulation, average, texture) and every entry of its
``period``, ``angle``, ``method`` and ``info`` (floats by their float64 bytes), so a speed-up that
claims the same numbers can be checked in one run. Prints one line per scene (``same`` or
``DIFFERENT``) and exits 1 when any scene differs; a scene that raises is compared by its error.

Example: python benchmarks/decode_digests.py /tmp/base/src src --large
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from source_trees import child_json  # noqa: E402  (beside this script)

FIELDS = ("phase", "mask", "quality", "phase_sigma", "wrapped", "modulation", "period", "angle", "method",
          "average", "texture", "info")


def digest(decoded) -> str:
    """SHA-256 of every field of a :class:`fringe3d.decode.Decoded` (:data:`FIELDS`)."""
    h = hashlib.sha256()

    def feed(x) -> None:
        if isinstance(x, dict):
            for k in sorted(x, key=str):
                h.update(repr(k).encode())
                feed(x[k])
        elif isinstance(x, (list, tuple)):
            h.update(b"L%d" % len(x))
            for v in x:
                feed(v)
        elif isinstance(x, np.ndarray):
            h.update(f"{x.dtype}{x.shape}".encode())
            h.update(np.ascontiguousarray(x).tobytes())
        elif isinstance(x, (float, np.floating)):
            h.update(np.float64(x).tobytes())
        else:
            h.update(repr(x).encode())
    for name in FIELDS:
        h.update(name.encode())
        feed(getattr(decoded, name, None))
    return h.hexdigest()


def _capture(h: int, w: int, ps, kind: str = "uint8", amp: float = 180, bias: float = 30, gamma: float | None = None):
    """Frames of a tilted, rippled ramp seen by an ``h`` x ``w`` camera (seed 0, noise 1 level)."""
    from fringe3d.patterns.synthetic import frames_from_coordinates
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    u_p = 5 + 0.665 * u * 1280 / w + 3 * np.sin(2 * np.pi * v / h)
    v_p = 20 + 0.5 * v * 1024 / h
    f = frames_from_coordinates(ps, u_p, v_p, bias, amp, noise=1.0, rng=np.random.default_rng(0), dtype=np.float64)
    if gamma is not None:
        f = 255.0 * (np.clip(f, 0, 255) / 255.0) ** gamma
    if kind == "uint16":
        return np.clip(f * 200, 0, 65535).astype(np.uint16)
    if kind == "float32":
        return (f / 255.0).astype(np.float32)
    return np.clip(np.rint(f), 0, 255).astype(np.uint8)


def scenes(large: bool):
    """``(name, frames, patterns, options)`` of every scene (see the module docstring)."""
    import bench_decode as bd
    from fringe3d.decode import DecodeOptions
    from fringe3d.patterns import sets
    from fringe3d.radiometry import power_law
    sizes = [(64, 80), (128, 160), (256, 320), (512, 640), (333, 257)] + ([(1024, 1280), (2048, 2560)] if large else [])
    for h, w in sizes:
        bd.H, bd.W = h, w
        ps15, f15, ps3, f3, _ = bd.make_frames()
        yield f"bench 15-frame {h}x{w}", f15, ps15, None
        yield f"bench 3-step {h}x{w}", f3, ps3, None
    h, w = 240, 300
    ps = sets.three_frequency("v", width=912, height=570)
    yield "clipped", _capture(h, w, ps, amp=260, bias=40), ps, None
    yield "dark", _capture(h, w, ps, amp=3, bias=1), ps, None
    yield "uint16", _capture(h, w, ps, "uint16"), ps, None
    yield "float32", _capture(h, w, ps, "float32"), ps, None
    g = _capture(h, w, ps, gamma=2.2)
    yield "gamma 2.2", g, ps, None
    yield "gamma 2.2, harmonic", g, ps, DecodeOptions(compensate="harmonic")
    yield "gamma 2.2, response", g, ps, DecodeOptions(compensate="response", response=power_law(2.0))
    yield "no edge mask", _capture(h, w, ps), ps, DecodeOptions(edge_mask=False)
    cal = sets.calibration(width=912, height=570)
    yield "calibration (v and h)", _capture(h, w, cal), cal, None
    for name, p in (("4-step", sets.phase_shift(18, 4, "v", width=912, height=570)),
                    ("9-step", sets.phase_shift(24, 9, "v", width=912, height=570)),
                    ("4-step + Gray code", sets.psp_with_gray_code(18, 4, "v", width=912, height=570)),
                    ("hierarchical", sets.hierarchical((18, 72, 912), (4, 4, 4), "v", width=912, height=570)),
                    ("3-step three-frequency", sets.three_frequency("v", steps=(3, 3, 3), width=912, height=570))):
        f = _capture(h, w, p, gamma=1.8)
        yield name, f, p, None
        if name == "3-step three-frequency":
            yield name + ", disagreement", f, p, DecodeOptions(compensate="disagreement")


def child(large: bool) -> dict:
    """``{scene: digest}`` with the library on the path (an error's type and text instead of a digest)."""
    from fringe3d.decode import decode
    out = {}
    for name, frames, ps, opts in scenes(large):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                out[name] = digest(decode(frames, ps, options=opts))
            except Exception as e:  # the same error in both trees is the same outcome
                out[name] = f"error {type(e).__name__}: {e}"
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", help="source tree A (the folder holding the fringe3d package)")
    ap.add_argument("b", help="source tree B")
    ap.add_argument("--large", action="store_true", help="also the 1280x1024 and 2560x2048 bench scenes")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.large)))
        return
    got = {}
    for tree in (args.a, args.b):
        got[tree] = child_json(tree, __file__, ["x", "x", "--child"] + (["--large"] if args.large else []))
    a, b = got[args.a], got[args.b]
    for name in a:
        print(f"{'same' if a[name] == b.get(name) else 'DIFFERENT':9s} {name}")
    differ = sum(a[n] != b.get(n) for n in a)
    print(f"{len(a) - differ} of {len(a)} scenes the same bytes")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
