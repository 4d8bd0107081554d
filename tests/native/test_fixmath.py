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
