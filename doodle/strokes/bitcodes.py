"""Bit-level codes of the binary stroke file: fixed-width fields and signed exponential-Golomb codes.

Exponential-Golomb codes of order ``k`` (as in H.264 and Draco-like geometry coders) spend few bits on small
numbers and grow by two bits each time a number doubles, so a delta that is usually small and sometimes large
costs little on average. A signed value ``v`` is first folded to ``u = 2v`` (``v ≥ 0``) or ``−2v − 1``; ``u``
is then written as ``q = u >> k`` in order 0 — ``L`` zeros, then ``q + 1`` in ``L + 1`` bits, where
``L = ⌊log₂(q + 1)⌋`` — followed by the ``k`` low bits of ``u``.

Bits are most significant first, as ``numpy.packbits`` packs them.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

#: Longest run of leading zeros a reader accepts: values up to 2⁴⁰ (positions use at most 32 bits, deltas 33).
MAX_ZEROS = 40
#: Width of the field that stores an order, and the highest order used or read (a 32-bit position's delta folds
#: under 2³⁴).
ORDER_BITS, MAX_ORDER = 6, 34
#: Largest folded value a reader accepts (int64 holds its unfolded value).
MAX_VALUE = 1 << 62


def pack(values: np.ndarray, bits: int) -> np.ndarray:
    """Unsigned integers → bit array (``uint8`` 0/1) of ``bits`` each, most significant first."""
    v = np.asarray(values).astype(np.uint64).ravel()
    shifts = np.arange(bits - 1, -1, -1, dtype=np.uint64)
    return ((v[:, None] >> shifts) & np.uint64(1)).astype(np.uint8).ravel()


def fold(values: np.ndarray) -> np.ndarray:
    """Signed integers → unsigned: 0, −1, 1, −2, … → 0, 1, 2, 3, …"""
    v = np.asarray(values, np.int64)
    return np.where(v >= 0, 2 * v, -2 * v - 1).astype(np.uint64)


def unfold(values: np.ndarray) -> np.ndarray:
    """Inverse of :func:`fold`."""
    u = np.asarray(values, np.int64)
    return np.where(u % 2 == 0, u // 2, -(u + 1) // 2)


def _leading(q: np.ndarray) -> np.ndarray:
    """``⌊log₂(q + 1)⌋`` for unsigned ``q`` (exact: ``frexp`` of an integer below 2⁵³)."""
    return np.frexp((q + np.uint64(1)).astype(np.float64))[1].astype(np.int64) - 1


def golomb_bits(values: np.ndarray, k: int) -> int:
    """Bits that :func:`golomb` spends on ``values`` (signed) at order ``k``."""
    q = fold(values) >> np.uint64(k)
    return int((2 * _leading(q) + 1 + k).sum())


def best_order(values: np.ndarray) -> int:
    """The order (0 … :data:`MAX_ORDER`) that codes ``values`` (signed) in the fewest bits."""
    if np.asarray(values).size == 0:
        return 0
    return min(range(MAX_ORDER + 1), key=lambda k: golomb_bits(values, k))


def golomb(values: np.ndarray, k: int) -> np.ndarray:
    """Signed integers → bit array of their exponential-Golomb codes of order ``k`` (see the module docstring)."""
    u = fold(values).ravel()
    if u.size == 0:
        return np.zeros(0, np.uint8)
    q = (u >> np.uint64(k)) + np.uint64(1)
    length = _leading(q - np.uint64(1))
    text = "".join("0" * int(n) + format(int(x), "b") + (format(int(r), f"0{k}b") if k else "")
                   for n, x, r in zip(length, q, u & np.uint64((1 << k) - 1)))
    return np.frombuffer(text.encode("ascii"), np.uint8) - np.uint8(48)


class BitReader:
    """Reads fixed-width fields and exponential-Golomb codes from a bit array, in order; reading past its end
    raises ``ValueError`` (the binary reader turns it into a :class:`~doodle.errors.StrokeFileError`)."""

    def __init__(self, bits: np.ndarray) -> None:
        self.bits = np.asarray(bits, np.uint8)
        self.pos = 0

    @cached_property
    def text(self) -> str:
        """The bits as ``"0"``/``"1"`` text, where :meth:`golomb` finds a code's leading zeros: made on its first
        use (a file before version 5, or without curves, reads fixed-width fields only)."""
        return (self.bits + np.uint8(48)).tobytes().decode("ascii")

    @property
    def left(self) -> int:
        return len(self.bits) - self.pos

    def take(self, count: int, bits: int) -> np.ndarray:
        """``count`` unsigned fields of ``bits`` each (``uint64``)."""
        end = self.pos + count * bits
        if end > len(self.bits):
            raise ValueError("bit stream ends early")
        chunk = self.bits[self.pos:end].reshape(count, bits).astype(np.uint64)
        self.pos = end
        return (chunk * (np.uint64(1) << np.arange(bits - 1, -1, -1, dtype=np.uint64))).sum(axis=1)

    def golomb(self, count: int, k: int) -> np.ndarray:
        """``count`` signed values coded by :func:`golomb` at order ``k``."""
        if not 0 <= k <= MAX_ORDER:
            raise ValueError(f"exponential-Golomb order {k} out of range")
        text, pos, out = self.text, self.pos, np.empty(count, np.uint64)
        for i in range(count):
            one = text.find("1", pos, pos + MAX_ZEROS + 1)
            if one < 0:
                raise ValueError("bad exponential-Golomb code")
            n = one - pos
            end = one + n + 1 + k
            if end > len(text):
                raise ValueError("bit stream ends early")
            value = ((int(text[one:one + n + 1], 2) - 1) << k) | (int(text[one + n + 1:end], 2) if k else 0)
            if value >= MAX_VALUE:
                raise ValueError("exponential-Golomb value out of range")
            out[i], pos = value, end
        self.pos = pos
        return unfold(out)
