"""Binary stripe codes for temporal phase unwrapping: simple binary and Gray code (ch. 1.2.2).

A code of ``bits`` bits labels stripes of width ``period`` along the fringe coordinate ``w``:
stripe ``c = floor((w - w0) / period)`` holds codeword ``c`` (simple binary) or ``c ^ (c >> 1)``
(Gray code). With ``period`` equal to the period of the phase it unwraps, the decoded stripe
index is the fringe order ``k`` (Eq. 1.5: ``Phi = phi + 2*pi*k`` with ``phi`` in ``[0, 2*pi)``).
Bit 0 is the most significant bit.
"""
from __future__ import annotations

import math

import numpy as np


def bits_needed(stripes: int) -> int:
    """Smallest bit count that labels ``stripes`` stripes (at least 1)."""
    if stripes < 1:
        raise ValueError(f"need at least one stripe, got {stripes}")
    return max(1, math.ceil(math.log2(stripes)))


def gray_encode(c: np.ndarray) -> np.ndarray:
    """Binary-reflected Gray code of non-negative integers ``c``.

    Parameters
    ----------
    c : array_like of int
        Non-negative integers (stripe indices).

    Returns
    -------
    ndarray
        int64 codewords ``c ^ (c >> 1)``, the shape of ``c``.

    Examples
    --------
    >>> import numpy as np
    >>> gray_encode(np.arange(4)).tolist()
    [0, 1, 3, 2]
    """
    c = np.asarray(c, dtype=np.int64)
    return c ^ (c >> 1)


def gray_decode(g: np.ndarray) -> np.ndarray:
    """Inverse of :func:`gray_encode` (prefix XOR), any integer array.

    Parameters
    ----------
    g : array_like of int
        Gray codewords.

    Returns
    -------
    ndarray
        int64 plain binary integers, the shape of ``g``.

    Examples
    --------
    >>> import numpy as np
    >>> gray_decode(gray_encode(np.arange(8))).tolist()
    [0, 1, 2, 3, 4, 5, 6, 7]
    """
    g = np.asarray(g, dtype=np.int64)
    c = g.copy()
    shift = 1
    while True:
        s = c >> shift
        if not np.any(s):
            break
        c ^= s
        shift *= 2
    return c


def stripe_index(w: np.ndarray, period: float, w0: float, bits: int) -> np.ndarray:
    """Stripe number ``floor((w - w0)/period)`` clipped to ``[0, 2**bits - 1]`` (int64)."""
    c = np.floor((np.asarray(w, dtype=np.float64) - w0) / period).astype(np.int64)
    return np.clip(c, 0, (1 << bits) - 1)


def code_bit(w: np.ndarray, period: float, w0: float, bit: int, bits: int, gray: bool) -> np.ndarray:
    """Value (0/1, uint8) of code bit ``bit`` (0 = MSB) at fringe coordinate ``w``."""
    if not 0 <= bit < bits:
        raise ValueError(f"code bit {bit} out of range for a {bits}-bit code")
    c = stripe_index(w, period, w0, bits)
    word = gray_encode(c) if gray else c
    return ((word >> (bits - 1 - bit)) & 1).astype(np.uint8)


def decode_bits(bit_images: np.ndarray, gray: bool) -> np.ndarray:
    """Codeword (stripe index) from thresholded bit images ``(bits, H, W)`` of 0/1, MSB first.

    Parameters
    ----------
    bit_images : (bits, H, W) array_like
        Thresholded bit images of 0/1, most significant bit first.
    gray : bool
        ``True`` for a Gray code (the word is Gray-decoded), ``False`` for simple binary.

    Returns
    -------
    ndarray
        ``(H, W)`` int64 stripe index.
    """
    b = np.asarray(bit_images).astype(np.int64)
    word = np.zeros(b.shape[1:], dtype=np.int64)
    for plane in b:
        word = (word << 1) | (plane & 1)
    return gray_decode(word) if gray else word
