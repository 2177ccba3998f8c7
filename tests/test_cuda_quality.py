"""The fused 3-step path's outputs made on the CUDA device (:meth:`FrameReconstructor.device_cycles`,
:mod:`fringe3d.gpu.quality_kernels`) equal the CPU backend's: quality bits exactly, masked ray
parameters, points, ``sigma_z`` and texture to float rounding; run under numba's CUDA simulator
in a separate process (``tests/cuda_sim_quality_worker.py``, 12 x 16 pixel frames). No physical
GPU is involved.
"""
from __future__ import annotations

import importlib.util
import inspect
from pathlib import Path

import numpy as np
import pytest
from cuda_sim_run import run_simulated

from fringe3d.decode import edges
from fringe3d.decode._fused_quality import fused_quality_map
from fringe3d.decode._stencils import PAIRS
from fringe3d.reconstruct.frame import GRADIENT_FLOOR

HERE = Path(__file__).parent
ROOT = HERE.parent
DEPTH_TOL = 1e-4  # mm, the ray parameters and points (float64 atan2 on the device, the CPU's polynomial)
SIGMA_RTOL = 1e-5  # sigma_z: the noise sums' float64 order, fused multiply-adds
TEX_TOL = 1e-6  # texture, a fraction of full scale
SETS = ("default", "strict")


@pytest.fixture(scope="module")
def simq(tmp_path_factory):
    return run_simulated("cuda_sim_quality_worker.py", tmp_path_factory.mktemp("cudasimq"), timeout=600)


def same_nan_and_close(a, b, atol=0.0, rtol=0.0):
    assert np.array_equal(np.isnan(a), np.isnan(b))
    ok = np.isfinite(a)
    assert ok.any()
    np.testing.assert_allclose(b[ok], a[ok], rtol=rtol, atol=atol)


@pytest.mark.parametrize("name", SETS)
def test_device_quality_bits_equal_the_cpu_bits_exactly(simq, name):
    np.testing.assert_array_equal(simq[f"{name}_gpu_quality"], simq[f"{name}_cpu_quality"])


def test_the_compared_maps_set_every_bit_of_the_fused_path(simq):
    q = np.concatenate([simq[f"{name}_cpu_quality"].ravel() for name in SETS])
    for bit in (edges.INVALID, edges.EDGE, edges.GRADIENT, edges.MOD_DROP, edges.RIM):
        assert (q & bit).any(), bit
    assert (q == 0).mean() > 0.3


@pytest.mark.parametrize("name", SETS)
def test_device_depth_points_sigma_z_and_texture_equal_cpu_to_float_rounding(simq, name):
    for key in ("depth", "points"):
        same_nan_and_close(simq[f"{name}_cpu_{key}"], simq[f"{name}_gpu_{key}"], atol=DEPTH_TOL)
    same_nan_and_close(simq[f"{name}_cpu_sigma_z"], simq[f"{name}_gpu_sigma_z"], rtol=SIGMA_RTOL)
    same_nan_and_close(simq[f"{name}_cpu_texture"], simq[f"{name}_gpu_texture"], atol=TEX_TOL)


def test_an_empty_phase_mask_gives_no_cycle_where_the_cpu_raises(simq):
    for name in SETS:
        assert bool(simq[f"{name}_cpu_empty_raises"]) and bool(simq[f"{name}_empty_is_none"])


def test_one_cycle_without_edge_tests_on_the_device_equals_cpu(simq):
    np.testing.assert_array_equal(simq["one_gpu_quality"], simq["one_cpu_quality"])
    assert set(np.unique(simq["one_gpu_quality"])) <= {0, edges.INVALID}
    same_nan_and_close(simq["one_cpu_depth"], simq["one_gpu_depth"], atol=DEPTH_TOL)
    assert bool(simq["one_gpu_none"])  # neither sigma_z nor texture asked for


def test_a_sequence_on_the_cuda_backend_stores_the_cpu_quality_and_sigma_z(simq):
    np.testing.assert_array_equal(simq["seq_cuda_quality"], simq["seq_cpu_quality"])
    assert (simq["seq_cpu_quality"] == 0).any()
    same_nan_and_close(simq["seq_cpu_sigma_z"], simq["seq_cuda_sigma_z"], rtol=SIGMA_RTOL)
    assert int(simq["seq_cpu_ply_files"]) == int(simq["seq_cuda_ply_files"]) == 2


def test_device_bit_values_and_gradient_floor_are_the_cpu_ones(simq):
    np.testing.assert_array_equal(simq["bits"], [edges.INVALID, edges.EDGE, edges.GRADIENT, edges.MOD_DROP, edges.RIM])
    assert GRADIENT_FLOOR == inspect.signature(fused_quality_map).parameters["gradient_floor"].default


def test_the_generated_device_median_is_the_cpu_selection_network():
    spec = importlib.util.spec_from_file_location("generate_cuda_median", ROOT / "scripts" / "generate_cuda_median.py")
    assert spec is not None and spec.loader is not None
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert (ROOT / "src" / "fringe3d" / "gpu" / "median_network.py").read_text() == gen.generate(PAIRS)
