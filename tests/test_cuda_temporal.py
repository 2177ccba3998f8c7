"""The decoder's default three-frequency (15-frame) decode with its assessment on the CUDA device
(:mod:`fringe3d.decode.device_temporal`, :mod:`fringe3d.gpu.temporal_kernels`) equals the CPU
backend's: the mask and the quality bits exactly, the phase, phase sigma and texture to float
rounding, the quality record (noise model, blur, margin, bit counts, saturation) likewise; run
under numba's CUDA simulator in a separate process (``tests/cuda_sim_temporal_worker.py``,
16 x 12 pixel frames, one capture and a brightened copy with clipped samples; ~20 s of CPU time). No physical GPU
is involved.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from cuda_sim_run import run_simulated

from fringe3d.decode import edges
from fringe3d.gpu import device_math
from fringe3d.phase import _kernels as phase_kernels

#: float32 phase (rad) of the fringe coordinate up to ~200 px: a last bit of the sums (the CPU
#: kernel's fused multiply-adds) moves it by one unit of the last place, 3.8e-6 rad at 30 rad.
PHASE_TOL = 1e-5
SIGMA_RTOL = 1e-4  # the noise model's float64 moments summed in another order, the modulation's last bit
TEX_TOL = 1e-6  # texture, a fraction of full scale
BLUR_RTOL = 1e-4  # the blur from the median modulation ratio (float32 ratios' last bit)
CASES = ("default_0", "default_1", "strict_1", "no_edges_1")


@pytest.fixture(scope="module")
def simt(tmp_path_factory):
    return run_simulated("cuda_sim_temporal_worker.py", tmp_path_factory.mktemp("cudasimt"), timeout=900)


def test_the_device_copies_the_cpu_kernels_atan2_polynomial():
    assert tuple(np.float32(c) for c in device_math.ATAN_COEFFICIENTS) == phase_kernels._FB


def test_every_cuda_decode_of_the_default_plan_took_the_device_path(simt):
    assert int(simt["device_calls"]) == len(CASES) + 1  # the decodes and the engine's


@pytest.mark.parametrize("case", CASES)
def test_device_mask_and_quality_bits_equal_the_cpu_exactly(simt, case):
    np.testing.assert_array_equal(simt[f"{case}_cuda_mask"], simt[f"{case}_cpu_mask"])
    np.testing.assert_array_equal(simt[f"{case}_cuda_quality"], simt[f"{case}_cpu_quality"])


def test_the_compared_maps_set_every_bit_of_the_three_frequency_assessment(simt):
    q = np.concatenate([simt[f"{case}_cpu_quality"].ravel() for case in CASES])
    for bit in (edges.INVALID, edges.EDGE, edges.INCONSISTENT, edges.GRADIENT, edges.MOD_DROP, edges.RIM,
                edges.SATURATED):
        assert (q & bit).any(), edges.BITS[bit]
    assert (simt["default_0_cpu_quality"] == 0).mean() > 0.5


@pytest.mark.parametrize("case", CASES)
def test_device_phase_sigma_and_texture_equal_cpu_to_float_rounding(simt, case):
    m = simt[f"{case}_cpu_mask"]
    assert m.any()
    for key in ("phase", "wrapped"):
        cpu, dev = simt[f"{case}_cpu_{key}"], simt[f"{case}_cuda_{key}"]
        assert np.array_equal(np.isnan(cpu), np.isnan(dev))
        assert np.abs(cpu - dev)[m].max() <= PHASE_TOL
    np.testing.assert_allclose(simt[f"{case}_cuda_modulation"], simt[f"{case}_cpu_modulation"], rtol=1e-5, atol=1e-4)
    s_cpu, s_dev = simt[f"{case}_cpu_phase_sigma"], simt[f"{case}_cuda_phase_sigma"]
    assert np.array_equal(np.isfinite(s_cpu), np.isfinite(s_dev)) and np.isfinite(s_cpu[m]).all()
    np.testing.assert_allclose(s_dev[m], s_cpu[m], rtol=SIGMA_RTOL)
    np.testing.assert_allclose(simt[f"{case}_cuda_texture"], simt[f"{case}_cpu_texture"], atol=TEX_TOL, rtol=0)


@pytest.mark.parametrize("case", CASES)
def test_device_quality_record_equals_the_cpu(simt, case):
    cpu, dev = (json.loads(str(simt[f"{case}_{b}_info"])) for b in ("cpu", "cuda"))
    assert dev["masked"] == cpu["masked"] and dev["saturation"] == cpu["saturation"]
    assert dev["noise"]["source"] == cpu["noise"]["source"]
    for key in ("c0", "c1"):
        assert math.isclose(dev["noise"][key], cpu["noise"][key], rel_tol=SIGMA_RTOL, abs_tol=1e-9)
    assert set(dev) == set(cpu)
    if "blur" in cpu:
        assert math.isclose(dev["blur"], cpu["blur"], rel_tol=BLUR_RTOL)
        assert math.isclose(dev["edge_margin"], cpu["edge_margin"], rel_tol=BLUR_RTOL)


def test_the_engine_on_the_device_gives_the_cpu_points_quality_and_sigma(simt):
    np.testing.assert_array_equal(simt["rec_cuda_quality"], simt["rec_cpu_quality"])
    for key, tol in (("points", 1e-3), ("sigma_xyz", 1e-5), ("texture", TEX_TOL)):
        cpu, dev = simt[f"rec_cpu_{key}"], simt[f"rec_cuda_{key}"]
        assert np.array_equal(np.isnan(cpu), np.isnan(dev)) and np.isfinite(cpu).any()
        np.testing.assert_allclose(dev[np.isfinite(cpu)], cpu[np.isfinite(cpu)], atol=tol, rtol=1e-5)


@pytest.mark.parametrize("n", (95, 96))
def test_device_median_of_the_blur_ratio_is_numpys_order_statistic(simt, n):
    assert int(simt[f"median_{n}_count"]) == n - 5  # 90 and 91: the mean of two middle values, and one
    assert float(simt[f"median_{n}_device"]) == float(simt[f"median_{n}_numpy"])


def _context(steps=(9, 3, 3), **options):
    from fringe3d.decode import DecodeOptions
    from fringe3d.decode.context import DecodeContext
    from fringe3d.patterns import sets

    ps = sets.three_frequency("v", steps=steps, width=256, height=200)
    frames = np.zeros((len(ps), 4, 5), np.uint8)
    return DecodeContext(frames=frames, patterns=ps, direction="v", plan=ps.plans[0],
                         options=DecodeOptions(**{"backend": "cuda", **options}))


@pytest.mark.parametrize("steps, options, expected", [
    ((9, 3, 3), {}, True),  # the default 15-frame set
    ((4, 3, 3), {}, True),
    ((3, 3, 3), {}, False),  # no fit residual for the noise model: the fused kernel alone on the device
    ((9, 3, 3), {"backend": "cpu"}, False),
    ((9, 3, 3), {"fused": False}, False),
    ((9, 3, 3), {"compensate": "disagreement"}, False),
])
def test_the_decoder_takes_the_device_path_only_for_the_fused_default_plan_on_cuda(steps, options, expected):
    from fringe3d.decode.device_temporal import on_device

    assert on_device(_context(steps, **options)) is expected
