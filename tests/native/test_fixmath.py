"""The fixed-point library, called in the native build through ctypes."""

import ctypes
import math

import numpy as np


def test_fx_tanh_stays_within_its_stated_bound(native_lib) -> None:  # noqa: ANN001
    f = native_lib.fx_tanh
    f.argtypes = [ctypes.c_int32, ctypes.c_uint8, ctypes.c_uint8]
    f.restype = ctypes.c_int32
    xs = np.linspace(-8, 8, 20001)
    worst = max(abs(f(int(round(x * 2**24)), 24, 30) / 2**30 - math.tanh(x)) for x in xs)
    assert worst <= 7e-4
    assert f(0, 24, 30) == 0 and f(-(2**24), 24, 30) == -f(2**24, 24, 30)


def test_fx_mul_rounds_to_nearest_and_saturates(native_lib) -> None:  # noqa: ANN001
    f = native_lib.fx_mul
    f.argtypes = [
        ctypes.c_int32,
        ctypes.c_uint8,
        ctypes.c_int32,
        ctypes.c_uint8,
        ctypes.c_uint8,
        ctypes.POINTER(ctypes.c_uint8),
    ]
    f.restype = ctypes.c_int32
    status = ctypes.c_uint8(0)
    assert f(3, 1, 1, 1, 1, ctypes.byref(status)) == 2  # 1.5 * 0.5 = 0.75 -> 1.0 (ties away)
    assert f(-3, 1, 1, 1, 1, ctypes.byref(status)) == -2
    assert status.value == 0
    assert f(2**30, 0, 4, 0, 0, ctypes.byref(status)) == 2**31 - 1
    assert status.value & 0x01  # SATURATED


def test_fx_mul_is_exact_rounding_of_the_product_over_random_operands(native_lib) -> None:  # noqa: ANN001
    """Against Python's integers: round half away from zero, saturate to int32."""
    f = native_lib.fx_mul
    f.argtypes = [ctypes.c_int32, ctypes.c_uint8, ctypes.c_int32, ctypes.c_uint8, ctypes.c_uint8]
    f.argtypes += [ctypes.POINTER(ctypes.c_uint8)]
    f.restype = ctypes.c_int32
    rng = np.random.default_rng(5)
    status = ctypes.c_uint8(0)
    for _ in range(20_000):
        bits_a, bits_b = rng.integers(1, 32, 2)
        a = (
            int(rng.integers(-(2**bits_a), 2**bits_a))
            if bits_a < 31
            else int(rng.integers(-(2**31), 2**31))
        )
        b = (
            int(rng.integers(-(2**bits_b), 2**bits_b))
            if bits_b < 31
            else int(rng.integers(-(2**31), 2**31))
        )
        qa, qb = (int(q) for q in rng.integers(0, 31, 2))
        q_out = int(rng.integers(max(0, qa + qb - 62), min(31, qa + qb) + 1))
        shift = qa + qb - q_out
        p = a * b
        m = (abs(p) + (1 << (shift - 1) if shift > 0 else 0)) >> shift
        want = max(-(2**31), min(2**31 - 1, m if p >= 0 else -m))
        assert f(a, qa, b, qb, q_out, ctypes.byref(status)) == want, (a, qa, b, qb, q_out)
