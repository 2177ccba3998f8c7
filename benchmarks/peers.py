"""Peer timings for bench_decode.py, run in the interpreter that has the peers installed.

Usage: python peers.py FRAMES3.npy REPEAT  -> one JSON object on stdout (seconds of every timed
call, ``*_seconds``, and their median, ``*_s``).

* ``fringes`` (non-commercial licence, benchmark only; never imported by fringe3d):
  (a) its own 15-frame 9+3+3-step three-frequency sequence at 1280x1024 decoded to the
  absolute coordinate (``Fringes.decode``, temporal multi-frequency unwrapping); (b) 3-step
  wrapped phase (``decode(unwrap=False)``). Its frames come from its own ``encode`` with the
  same size, frame count and wavelength ratios 18:21:144, scaled by 1024/1008 so the
  beat covers its 1024 px axis (it decodes only what it encodes).
* OpenCV ``structured_light.SinusoidalPattern`` (PSP, 3 steps): ``computePhaseMap`` on the
  same 3-step frames fringe3d decodes in (b). OpenCV has no multi-frequency decoder: (a) n/a.

A peer that is not importable is reported as ``"not installed"``.
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np


def _times(fn, repeat):
    """Seconds of ``repeat`` calls of ``fn`` after one warm-up (JIT, caches)."""
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return ts


def bench_fringes(height, width, repeat):
    try:
        import logging

        import fringes
        logging.getLogger("fringes").setLevel(logging.ERROR)
    except Exception as e:  # noqa: BLE001
        return {"status": "not installed", "error": str(e)}
    import warnings
    warnings.simplefilter("ignore")
    out = {"status": "ok", "version": getattr(fringes, "__version__", "?")}
    f = fringes.Fringes(X=width, Y=height, axes=(0,), K=3, N=(9, 3, 3))
    L = float(np.atleast_1d(f.L)[0])
    lam = np.array([18.0, 21.0, 144.0]) * L / 1008.0  # ratios 18:21:144, beat (unambiguous range) = L
    f.v = tuple(L / lam)
    seq = f.encode()
    t0 = time.perf_counter()
    dec = f.decode(seq)
    out["a_first_call_s"] = time.perf_counter() - t0
    coord = np.asarray(dec.x).reshape(height, width)
    truth = np.arange(height, dtype=np.float64)[:, None] * np.ones((1, width))
    err = np.mod(coord - truth + L / 2, L) - L / 2  # the coordinate is defined modulo its range L
    out["a_coordinate_rms_px"] = float(np.sqrt(np.nanmean(err ** 2)))
    out["a_wavelengths_px"] = [float(x) for x in lam]
    out["a_seconds"] = _times(lambda: f.decode(seq), repeat)
    out["a_s"] = float(np.median(out["a_seconds"]))
    f1 = fringes.Fringes(X=width, Y=height, axes=(0,), K=1, N=(3,))
    f1.v = (L / lam[0],)
    seq1 = f1.encode()
    out["b_seconds"] = _times(lambda: f1.decode(seq1, unwrap=False), repeat)
    out["b_s"] = float(np.median(out["b_seconds"]))
    return out


def bench_opencv(frames3, repeat):
    try:
        import cv2
        sl = cv2.structured_light
    except Exception as e:  # noqa: BLE001
        return {"status": "not installed", "error": str(e)}
    h, w = frames3.shape[1:]
    p = sl.SinusoidalPattern.Params()
    p.width, p.height, p.nbrOfPeriods = w, h, max(1, round(w / 18))
    p.methodId, p.shiftValue, p.horizontal, p.setMarkers = sl.PSP, float(2 * np.pi / 3), False, False
    pat = sl.SinusoidalPattern_create(p)
    imgs = [np.ascontiguousarray(f) for f in frames3]
    phase, _ = pat.computePhaseMap(imgs)
    ts = _times(lambda: pat.computePhaseMap(imgs), repeat)
    return {"status": "ok", "version": cv2.__version__, "b_seconds": ts, "b_s": float(np.median(ts)),
            "b_output_dtype": str(np.asarray(phase).dtype)}


def main():
    frames3 = np.load(sys.argv[1])
    repeat = int(sys.argv[2])
    h, w = frames3.shape[1:]
    print(json.dumps({"fringes": bench_fringes(h, w, repeat), "opencv": bench_opencv(frames3, repeat)}))


if __name__ == "__main__":
    main()
