"""The 3-step PSP pass's saturation map, tested in the frames' own dtype, against its float64
definition: ``float64(max_k I_k) >= saturation_level``, the max taken as Python's ``max`` takes it."""
import numpy as np
import pytest

from fringe3d.phase._kernels import SAT_ALWAYS, SAT_FLOAT64, SAT_NATIVE, SAT_NEVER, saturation_test
from fringe3d.phase.psp import wrapped_phase

F32_MAX = float(np.finfo(np.float32).max)


def _python_max_at_least(frames, level):
    """``float64(max(x0, max(x1, x2))) >= level`` per pixel, ``max(a, b) = b if b > a else a``."""
    x0, x1, x2 = frames
    inner = np.where(x2 > x1, x2, x1)
    peak = np.where(inner > x0, inner, x0)
    return peak.astype(np.float64) >= level


def _frames(dtype, rng):
    dtype = np.dtype(dtype)
    shape = (3, 7, 50)
    if dtype.kind == "f":
        f = rng.normal(0.0, 300.0, shape).astype(dtype)
        f.flat[::37] = np.nan
        f.flat[5::41] = np.inf
        f.flat[9::43] = -np.inf
        f.flat[11::47] = np.finfo(dtype).max
        f.flat[13::53] = 255.0
        return f
    info = np.iinfo(dtype)
    f = rng.integers(max(info.min, -70000), min(info.max, 70000), shape, endpoint=True).astype(dtype)
    f.flat[::31] = info.max
    f.flat[7::29] = info.min
    f.flat[3::17] = 255
    return f


LEVELS = [255.0, 254.5, 255.0000001, 0.0, -3.5, 1e300, -1e300, np.inf, -np.inf, np.nan, 65535.0, 65535.5,
          F32_MAX, np.nextafter(F32_MAX, np.inf), 2.0 ** 63, 2.0 ** 64]


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.int64, np.float32])
def test_three_frame_saturation_map_equals_its_float64_definition(dtype):
    rng = np.random.default_rng(7)
    f = _frames(dtype, rng)
    for level in LEVELS:
        _, sat = wrapped_phase(f, saturation_level=level, return_saturated=True)
        np.testing.assert_array_equal(sat, _python_max_at_least(f, level), err_msg=f"{np.dtype(dtype)} {level}")


@pytest.mark.parametrize("level", LEVELS)
def test_saturation_test_threshold_decides_like_the_float64_comparison(level):
    # every float32 near the threshold (and the extremes) decides as float64(x) >= level does
    mode, t = saturation_test(np.dtype(np.float32), level)
    near = np.float32(np.clip(level, -F32_MAX, F32_MAX)) if not np.isnan(level) else np.float32(0.0)
    with np.errstate(over="ignore"):  # the neighbours of the largest float32 are infinite
        xs = np.array([np.nextafter(near, np.float32(-np.inf)), near, np.nextafter(near, np.float32(np.inf)),
                       np.inf, -np.inf, np.nan, 0.0, F32_MAX, -F32_MAX], np.float32)
    want = xs.astype(np.float64) >= level
    got = {SAT_NEVER: np.zeros(xs.size, bool), SAT_ALWAYS: np.ones(xs.size, bool)}.get(mode)
    if got is None:
        assert mode == SAT_NATIVE
        got = xs >= t[0]
    np.testing.assert_array_equal(got, want)
    assert saturation_test(np.dtype(np.int64), level)[0] == SAT_FLOAT64  # float64 does not hold every int64


@pytest.mark.parametrize("dtype", [np.uint16, np.float32])
def test_three_frame_pass_equals_the_previous_kernel_bit_for_bit(dtype):
    # the one-loop float64 sums and the fused float32 loop give the outputs of the form with
    # float64 buffers (accumulate_chunk) and numpy-free atan2 constants, NaN and inf included
    from reference_implementations import psp_kernel_previous, run_psp_kernel

    from fringe3d.phase.psp import lsq_coefficients
    rng = np.random.default_rng(3)
    f = _frames(dtype, rng)[:, :, :43]
    if np.dtype(dtype).kind == "f":
        f[1, 2, :5] = 0.0
        f[0, 2, :5] = f[2, 2, :5] = 7.0  # I1 = I3: a zero numerator
    coef, level = lsq_coefficients((-2.0 * np.pi / 3.0, 0.0, 2.0 * np.pi / 3.0)), 255.0
    got = [np.empty(f.shape[1:], np.float32) for _ in range(3)] + [np.empty(f.shape[1:], bool)]
    want = [np.empty(f.shape[1:], np.float32) for _ in range(3)] + [np.zeros(f.shape[1:], bool)]
    none = (np.empty((0, 0), bool), np.empty((0, 0), np.float32), np.empty((0, 0), np.uint8), np.zeros(0),
            np.zeros(0, np.int64))
    run_psp_kernel(f, np.arange(3), coef, level, *got, np.float32(0), *none)
    psp_kernel_previous(f.astype(np.float64), np.arange(3), coef, level, *want)
    for g, w in zip(got, want):
        assert g.tobytes() == w.tobytes()
