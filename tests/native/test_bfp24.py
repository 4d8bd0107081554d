"""linalg/bfp24 (float32 blocks with 24-bit mantissas, exact integer dot products rounded
once) in the native build, against the same definitions in Python's integers."""

import ctypes
import math
import struct
from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

NOT_FINITE = 0x4000
SIGN = 1 << 31

floats32 = st.floats(width=32, allow_nan=False, allow_infinity=False)
words = st.builds(lambda m, s: m | (SIGN if s else 0), st.integers(0, 2**24 - 1), st.booleans())


def _bits(x: float) -> int:
    return struct.unpack("<I", struct.pack("<f", x))[0]


def _f32(bits: int) -> float:
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def block(xs: list[float]) -> tuple[list[int], int]:
    """bfp24_from_f32's definition: one exponent, the largest mantissa kept whole, the
    others truncated toward zero."""
    parts = []
    for x in xs:
        b = _bits(x)
        ex = (b >> 23) & 0xFF
        if ex == 0xFF:
            return [], NOT_FINITE
        parts.append((b & SIGN, max(ex, 1), (b & 0x7FFFFF) | (0x800000 if ex else 0)))
    top = max([1] + [ex for _, ex, _ in parts])
    return [s | (mag >> (top - ex) if top - ex < 24 else 0) for s, ex, mag in parts], top - 150


def value(word: int) -> int:
    return -(word & 0xFFFFFF) if word & SIGN else word & 0xFFFFFF


def round_f32(s: int, e: int) -> float:
    """s 2^e to nearest-even float32, ±inf past FLT_MAX, ±0 below FLT_MIN."""
    if s == 0:
        return 0.0
    sign, mag = (-1.0 if s < 0 else 1.0), Fraction(abs(s)) * Fraction(2) ** e
    ex = math.floor(math.log2(mag))
    ex += 1 if mag >= Fraction(2) ** (ex + 1) else -1 if mag < Fraction(2) ** ex else 0
    scaled = mag / Fraction(2) ** (ex - 23)  # in [2^23, 2^24)
    m = math.floor(scaled)
    if scaled - m > Fraction(1, 2) or (scaled - m == Fraction(1, 2) and m % 2):
        m += 1
    if m == 2**24:
        m, ex = m // 2, ex + 1
    if ex > 127:
        return sign * math.inf
    if ex < -126:
        return sign * 0.0
    return sign * float(Fraction(m) * Fraction(2) ** (ex - 23))


def _lib(native_lib):  # noqa: ANN001, ANN202
    lib = native_lib
    lib.bfp24_from_f32_c.argtypes = [ctypes.POINTER(ctypes.c_float), ctypes.c_uint8]
    lib.bfp24_from_f32_c.argtypes += [ctypes.POINTER(ctypes.c_uint32)]
    lib.bfp24_from_f32_c.restype = ctypes.c_int16
    lib.bfp24_dot_c.argtypes = [ctypes.POINTER(ctypes.c_uint32)] * 2 + [ctypes.c_uint8]
    lib.bfp24_dot_c.restype = ctypes.c_int64
    lib.bfp24_to_f32_c.argtypes = [ctypes.c_int64, ctypes.c_int16]
    lib.bfp24_to_f32_c.restype = ctypes.c_float
    return lib


def _c_block(lib, xs: list[float]) -> tuple[list[int], int]:  # noqa: ANN001
    n = len(xs)
    out = (ctypes.c_uint32 * n)()
    e = lib.bfp24_from_f32_c((ctypes.c_float * n)(*xs), n, out)
    return list(out), e


@settings(max_examples=300, deadline=None)
@given(st.lists(floats32, min_size=1, max_size=12))
def test_a_block_keeps_the_largest_whole_and_truncates_the_rest(native_lib, xs) -> None:  # noqa: ANN001
    lib = _lib(native_lib)
    got = _c_block(lib, xs)
    assert got == block(xs)
    m, e = got
    top = max(abs(x) for x in xs)
    for x, w in zip(xs, m, strict=True):
        assert abs(Fraction(x) - value(w) * Fraction(2) ** e) < Fraction(2) ** e
        assert ((w & SIGN) != 0) == (math.copysign(1, x) < 0)
    if top > 0:
        assert max(w & 0xFFFFFF for w in m) >= 2**23 or e == -149


def test_a_block_with_an_infinity_or_a_nan_is_not_finite(native_lib) -> None:  # noqa: ANN001
    lib = _lib(native_lib)
    assert _c_block(lib, [1.0, math.inf])[1] == NOT_FINITE
    assert _c_block(lib, [math.nan, 0.0])[1] == NOT_FINITE
    assert _c_block(lib, [0.0, -0.0]) == ([0, SIGN], -149)
    assert _c_block(lib, [1e-45, 3e-45])[0] == [1, 2]  # subnormals exactly


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(words, words), min_size=0, max_size=255))
def test_the_dot_product_is_exact(native_lib, pairs) -> None:  # noqa: ANN001
    lib = _lib(native_lib)
    n = len(pairs)
    a = (ctypes.c_uint32 * max(n, 1))(*[p[0] for p in pairs])
    b = (ctypes.c_uint32 * max(n, 1))(*[p[1] for p in pairs])
    assert lib.bfp24_dot_c(a, b, n) == sum(value(x) * value(y) for x, y in pairs)


@settings(max_examples=2000, deadline=None)
@given(st.integers(-(2**62), 2**62), st.integers(-330, 250))
def test_rounding_once_is_to_nearest_even(native_lib, s, e) -> None:  # noqa: ANN001
    got = _lib(native_lib).bfp24_to_f32_c(s, e)
    want = round_f32(s, e)
    assert got == want and math.copysign(1, got) == math.copysign(1, want), (s, e)


def test_rounding_at_the_edges(native_lib) -> None:  # noqa: ANN001
    f = _lib(native_lib).bfp24_to_f32_c
    cases = [
        (2**24 + 1, 0),  # a tie, to even: 2^24
        (2**24 + 3, 0),  # a tie, to even: 2^24 + 4
        (2**25 - 1, 0),  # rounds up into the next binade
        (-(2**63) + 1, 0),
        (1, -149),  # below FLT_MIN: 0
        (1, -126),  # FLT_MIN
        (2**24 - 1, 104),  # FLT_MAX
        (2**25 - 1, 103),  # rounds past FLT_MAX: inf
        (-(2**40) - 2**16 - 1, -3),  # sticky bits far below
        (2**40 + 2**16, -3),  # a tie with nothing below
    ]
    for s, e in cases:
        assert f(s, e) == round_f32(s, e), (s, e)
    assert f(2**24 + 1, 0) == 2.0**24 and f(2**24 + 3, 0) == 2.0**24 + 4
    assert f(2**25 - 1, 103) == math.inf and f(-(2**25) + 1, 103) == -math.inf
    assert f(0, 0) == 0.0 and f(1, -127) == 0.0


def test_a_gram_entry_is_the_exact_dot_product_rounded_when_nothing_is_truncated() -> None:
    """Blocks of floats within 2^0 of each other lose nothing: the result is the exact
    dot product of the floats, rounded once."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        a = (rng.uniform(1, 2, 9) * rng.choice([-1, 1], 9)).astype(np.float32).tolist()
        b = (rng.uniform(1, 2, 9) * rng.choice([-1, 1], 9)).astype(np.float32).tolist()
        (ma, ea), (mb, eb) = block(a), block(b)
        s = sum(value(x) * value(y) for x, y in zip(ma, mb, strict=True))
        exact = sum(Fraction(x) * Fraction(y) for x, y in zip(a, b, strict=True))
        assert s * Fraction(2) ** (ea + eb) == exact


@settings(max_examples=500, deadline=None)
@given(st.lists(st.integers(-(2**63) + 1, 2**63 - 1), min_size=0, max_size=12))
def test_sums_into_a_block_keep_24_bits_of_the_largest(native_lib, values) -> None:  # noqa: ANN001
    f = native_lib.bfp24_from_i64_c
    f.argtypes = [ctypes.POINTER(ctypes.c_int64), ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint32)]
    f.restype = ctypes.c_uint8
    n = len(values)
    out = (ctypes.c_uint32 * max(n, 1))()
    k = f((ctypes.c_int64 * max(n, 1))(*values), n, out)
    assert k == max(0, max([abs(v) for v in values] + [0]).bit_length() - 24)
    assert list(out)[:n] == [(abs(v) >> k) | (SIGN if v < 0 else 0) for v in values]
