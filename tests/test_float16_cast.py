"""The store's float32 -> float16 cast (:func:`fringe3d.io._float16.to_float16`) equals numpy's
``astype(np.float16)`` bit for bit (round to nearest even, overflow, subnormals, NaN, signs)."""
import numpy as np
import pytest

from fringe3d.io import _float16
from fringe3d.io._float16 import to_float16


@pytest.fixture(params=["portable", "hardware"], autouse=True)
def cast_pass(request, monkeypatch):
    """Every test on both passes: the bit arithmetic and, where the processor has it, its own
    float32 -> float16 conversion (:data:`fringe3d.io._float16.HARDWARE`)."""
    if request.param == "hardware" and not _float16._has_hardware_half():
        pytest.skip("this processor has no float32 -> float16 conversion instruction")
    monkeypatch.setattr(_float16, "HARDWARE", request.param == "hardware")
    return request.param


def _numpy_half_bits(bits: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        return bits.view(np.float32).astype(np.float16).view(np.uint16)


def test_cast_equals_numpy_around_every_half_value_and_midpoint():
    # every float16 value and every midpoint between neighbours (the ties), as float32 bits,
    # with 64 float32 ulps either side, both signs, plus inf / NaN patterns
    exact = np.arange(1 << 15, dtype=np.uint16).view(np.float16).astype(np.float32).view(np.uint32)
    exact = exact[exact < 0x7F800000]
    mid = ((exact[:-1].astype(np.int64) + exact[1:]) // 2)
    special = np.array([0x7F800000, 0x7F800001, 0x7F801FFF, 0x7F802000, 0x7FC00000, 0x7FFFFFFF, 0x477FF000,
                        0x477FEFFF, 0x47800000, 0x33000000, 0x33000001, 0x32FFFFFF, 0x38800000, 0x387FFFFF], np.int64)
    base = np.concatenate([exact.astype(np.int64), mid, special])
    bits = (base[:, None] + np.arange(-64, 65)).ravel()
    bits = bits[(bits >= 0) & (bits <= 0x7FFFFFFF)].astype(np.uint32)
    bits = np.concatenate([bits, bits | np.uint32(0x80000000)])
    got = to_float16(bits.view(np.float32)).view(np.uint16)
    np.testing.assert_array_equal(got, _numpy_half_bits(bits))


def test_cast_equals_numpy_on_random_bit_patterns_and_keeps_the_shape():
    bits = np.random.default_rng(7).integers(0, 1 << 32, (1024, 1024), dtype=np.uint64).astype(np.uint32)
    got = to_float16(bits.view(np.float32))
    assert got.dtype == np.float16 and got.shape == bits.shape
    np.testing.assert_array_equal(got.view(np.uint16), _numpy_half_bits(bits))


def test_non_float32_input_goes_through_numpy():
    x = np.array([1e-8, 0.1, 70000.0, np.nan], np.float64)
    with np.errstate(over="ignore"):
        np.testing.assert_array_equal(to_float16(x).view(np.uint16), x.astype(np.float16).view(np.uint16))
