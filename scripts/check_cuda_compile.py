"""Compile every CUDA kernel of :mod:`fringe3d.gpu` for a real GPU architecture, without a GPU.

The simulator tests (``tests/test_cuda_backend.py``) run the kernels' Python; they cannot show
that the CUDA compiler accepts them. This script compiles each kernel, for the argument types the
host code passes, to PTX with the CUDA toolkit's NVVM (no driver needed) and, when ``ptxas`` is
found, assembles it for the target, printing registers and spills. Needs a CUDA toolkit (NVVM;
e.g. ``/usr/local/cuda``), not a device. Exit status 1 when any kernel fails.

Run: ``python scripts/check_cuda_compile.py [--cc 9.0] [--ptxas /usr/local/cuda/bin/ptxas]``
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile


def signatures():
    """(name, kernel, argument types) of each kernel for the frame dtypes the host code passes."""
    from numba import types as t

    from fringe3d.gpu import phase_kernels as pk
    from fringe3d.gpu import quality_kernels as qk
    from fringe3d.gpu import temporal_kernels as tm
    from fringe3d.gpu import triangulate_kernels as tk
    from fringe3d.gpu import unwrap_kernels as uk

    def A(dt, nd):
        return t.Array(dt, nd, "C")

    f32, f64, i64, i32, i8, u8, b1 = t.float32, t.float64, t.int64, t.int32, t.int8, t.uint8, t.boolean
    out = []
    for fr in (t.uint8, t.uint16, t.float32):
        out += [
            (f"psp[{fr}]", pk.psp_kernel, (A(fr, 3), A(i64, 1), A(f64, 2), f64, A(f32, 2), A(f32, 2), A(f32, 2),
                                           A(b1, 2))),
            (f"three_frequency[{fr}]", uk.three_frequency_kernel,
             (A(fr, 3), A(i64, 1), A(f32, 2), A(i64, 1), A(f32, 2), A(i64, 1), A(f32, 2), A(f32, 1),
              A(f32, 2), A(f32, 2), A(f32, 2), A(f32, 2), A(b1, 2), A(f32, 2))),
            (f"three_step[{fr}]", tk.three_step_kernel,
             (A(fr, 3), A(i64, 1), A(f64, 2), f64, A(f32, 1), A(i8, 1), f64, A(f64, 1), A(f32, 2), A(f64, 1),
              A(f64, 1), A(f32, 3))),
            (f"three_step_depth[{fr}]", tk.three_step_depth_kernel,
             (A(fr, 3), A(i64, 1), A(f64, 2), f64, A(f32, 1), A(i8, 1), f64, A(f64, 1), A(f32, 2), A(f64, 1),
              A(f64, 1), A(f32, 2))),
            (f"three_step_fields[{fr}]", qk.three_step_fields_kernel,
             (A(fr, 3), A(i64, 1), A(f64, 2), f64, A(f32, 1), A(i8, 1), f64, A(f64, 1), A(f32, 2), A(f64, 1),
              A(f64, 1), f32, A(f32, 2), A(f32, 2), A(f32, 2), A(f32, 2), b1, A(f32, 2))),
            (f"tf_assess[{fr}]", tm.three_frequency_assess_kernel,
             (A(fr, 2), A(i64, 1), A(f32, 2), A(i64, 1), A(f32, 2), A(i64, 1), A(f32, 2), A(f32, 1), A(f32, 2),
              A(f64, 1), A(f64, 2)) + (A(f32, 1),) * 4 + (A(b1, 1), A(f32, 1), A(b1, 2)) + (A(f32, 1),) * 3),
        ]
    out += [("geometric", uk.geometric_kernel, (A(f32, 2), A(f32, 1), A(i8, 1), A(b1, 2), b1, A(f32, 2), A(b1, 2))),
            ("central_points", tk.central_points_kernel, (A(f64, 2), A(b1, 2), A(f64, 1), A(f32, 2), A(f64, 1),
                                                          A(f64, 1), A(f32, 3))),
            ("jump_contrast", qk.jump_contrast_kernel, (A(f32, 2),) * 4 + (i64, i64, A(f32, 2), A(f32, 2))),
            ("gradient_test", qk.gradient_test_kernel, (A(f32, 2), A(f32, 2), i64, i64, f32, f32, A(b1, 2))),
            ("quality_bits", qk.quality_bits_kernel, (A(f32, 2), A(f32, 2), A(b1, 2), A(f32, 2), i64, i64, f32, f32,
                                                      f32, i64, b1, A(u8, 2), A(f32, 2))),
            ("laplacian_partials", qk.laplacian_partials_kernel, (A(f32, 2), A(u8, 2), i64, i64, A(f64, 2),
                                                                  A(i32, 2))),
            ("noise", qk.noise_kernel, (A(f64, 2), A(i32, 2), f64, f32, A(f32, 2))),
            ("sigma_z", qk.sigma_z_kernel, (A(f32, 2), A(f32, 2), A(u8, 2), A(f32, 2), f32, A(f64, 1), A(f64, 1),
                                            A(f64, 1), A(f32, 2), A(f32, 2))),
            ("tf_apply_broken", tm.apply_broken_kernel, (A(b1, 1), A(b1, 1), A(f32, 1))),
            ("tf_count_rows", tm.count_rows_kernel, (A(b1, 2), A(i32, 2))),
            ("tf_strided_sample", tm.strided_sample_kernel, (A(f32, 1), A(f32, 1), A(b1, 1), i64, i64, i64, A(f32, 1),
                                                              A(f32, 1), A(b1, 1))),
            ("tf_line_moments", tm.line_moments_kernel, (A(f32, 1), A(f32, 1), A(b1, 1)) + (f64,) * 5
             + (A(f64, 2),)),
            ("tf_ratio", tm.ratio_kernel, (A(f32, 1), A(f32, 1), A(b1, 1), A(f32, 1), A(i32, 2))),
            ("tf_radix_histogram", tm.radix_histogram_kernel, (A(t.uint32, 1), t.uint32, t.uint32, i64, A(i32, 1))),
            ("tf_w", tm.w_kernel, (A(f32, 1), f32, A(f32, 1))),
            ("tf_finish", tm.finish_kernel, (A(u8, 1), A(b1, 1), A(f32, 1), A(b1, 1), b1, A(f32, 1), f32, b1, b1)),
            ("tf_phase_sigma", tm.phase_sigma_kernel, (A(f32, 1),) * 3 + (f32,) * 4 + (b1, f32, A(f32, 1),
                                                                                    A(f32, 1)))]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cc", default="9.0", help="compute capability, e.g. 9.0 (H100/H200), 8.0 (A100), 8.6")
    ap.add_argument("--ptxas", default=shutil.which("ptxas") or "/usr/local/cuda/bin/ptxas")
    args = ap.parse_args(argv)
    cc = tuple(int(x) for x in args.cc.split("."))
    import numba.cuda.dispatcher as dispatcher
    from numba import cuda

    class _Target:  # device functions ask the current device for its architecture; name it instead
        compute_capability = cc

    dispatcher.get_current_device = lambda: _Target()  # type: ignore[attr-defined]
    failed = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name, kernel, sig in signatures():
            try:
                ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=cc)
            except Exception as e:  # noqa: BLE001 - report every kernel
                print(f"{name:28s} FAILED: {type(e).__name__}: {str(e).splitlines()[-1]}")
                failed += 1
                continue
            line = f"{name:28s} PTX ok ({len(ptx)} chars)"
            if os.path.exists(args.ptxas):
                path = os.path.join(tmp, "k.ptx")
                with open(path, "w") as fh:
                    fh.write(ptx)
                p = subprocess.run([args.ptxas, f"-arch=sm_{cc[0]}{cc[1]}", "-v", path, "-o", path + ".cubin"],
                                   capture_output=True, text=True)
                info = [s.split(":", 1)[-1].strip() for s in p.stderr.splitlines() if "registers" in s or "spill" in s]
                line += f"; ptxas sm_{cc[0]}{cc[1]} " + ("ok: " + "; ".join(info) if p.returncode == 0 else
                                                         "FAILED: " + p.stderr.strip()[-300:])
                failed += p.returncode != 0
            print(line)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
