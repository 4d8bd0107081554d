"""The fixed-point library, called in the native build through ctypes."""

import ctypes
import math

import numpy as np


def test_fx_tanh_stays_within_its_stated_bound(native_lib) -> None:  # noqa: ANN001
    """The Q15 table's interpolation, from |x| in Q19: 3.92e-4 at most inside [0, 4)."""
    f = native_lib.fx_tanh_q15_pos
    f.argtypes = [ctypes.c_uint32]
    f.restype = ctypes.c_uint16
    pos = np.arange(0, 64 << 15, 5)
    worst = max(abs(f(int(p)) / 2**15 - math.tanh(p / 2**19)) for p in pos)
    assert worst <= 4e-4
    assert f(0) == 0 and f((64 << 15) - 1) <= 32746


def test_tanh_f32_stays_within_its_stated_bound(native_lib) -> None:  # noqa: ANN001
    f = native_lib.tanh_f32
    f.argtypes = [ctypes.c_float]
    f.restype = ctypes.c_float
    xs = np.concatenate([np.linspace(-12, 12, 40_001), np.geomspace(1e-12, 12, 5_000)])
    xs = xs.astype(np.float32)
    worst = max(abs(f(float(x)) - math.tanh(float(x))) for x in xs)
    assert worst < 3e-5
    assert f(float("inf")) == 1.0 and f(float("-inf")) == -1.0 and math.isnan(f(float("nan")))
    assert f(1e-30) == np.float32(1e-30) and math.copysign(1, f(-0.0)) == -1


def test_fx_mul_rounds_to_nearest_and_saturates(native_lib) -> None:  # noqa: ANN001
    f = native_lib.fx_mul_wide
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
    f = native_lib.fx_mul_wide
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


def _kernel(native_lib, name):  # noqa: ANN001, ANN202
    f = getattr(native_lib, name)
    f.argtypes = [ctypes.c_int32, ctypes.c_int32, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint8)]
    f.restype = ctypes.c_int32
    return f


def _operands(rng, n):  # noqa: ANN001, ANN202
    """Random int32s of every magnitude, and the edges."""
    edges = [0, 1, -1, 2**31 - 1, -(2**31), 2**30, -(2**30), 2**15, -(2**15) - 1]
    bits = rng.integers(0, 32, n)
    mags = [int(rng.integers(0, 2 ** int(b))) if b else 0 for b in bits]
    signs = rng.choice([-1, 1], n)
    return edges + [
        max(-(2**31), min(2**31 - 1, int(s) * m)) for s, m in zip(signs, mags, strict=True)
    ]


def test_the_multiply_kernels_round_and_saturate_as_stated_for_every_shift(native_lib) -> None:  # noqa: ANN001
    """fx_mul_rs_c (ties away from zero) and fx_mul_shr_c (half up), the C twins of the AVR
    entries, against Python's integers on edge and random operands at every shift."""
    rs, shr = _kernel(native_lib, "fx_mul_rs_c"), _kernel(native_lib, "fx_mul_shr_c")
    rng = np.random.default_rng(17)
    ops = _operands(rng, 300)
    for s in range(1, 63):
        for a, b in zip(ops, rng.permutation(ops), strict=True):
            b = int(b)
            p, h = a * b, 1 << (s - 1)
            away = (abs(p) + h) >> s
            for f, want in ((rs, away if p >= 0 else -away), (shr, (p + h) >> s)):
                status = ctypes.c_uint8(0)
                got = f(a, b, s, ctypes.byref(status))
                clipped = max(-(2**31), min(2**31 - 1, want))
                assert got == clipped, (f, a, b, s)
                assert bool(status.value & 0x01) == (clipped != want), (f, a, b, s)


def test_fx_mul16_gives_the_bits_of_fx_mul_rs(native_lib) -> None:  # noqa: ANN001
    """The int32 × int16 kernel against the int32 × int32 one, edges and random operands."""
    rs = _kernel(native_lib, "fx_mul_rs_c")
    m16 = native_lib.fx_mul16_c
    m16.argtypes = [ctypes.c_int32, ctypes.c_int16, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint8)]
    m16.restype = ctypes.c_int32
    rng = np.random.default_rng(16)
    ops = _operands(rng, 120)
    bs = [0, 1, -1, 2**15 - 1, -(2**15)] + [int(b) for b in rng.integers(-(2**15), 2**15, 200)]
    for s in range(1, 31):
        for a in ops:
            for b in bs[:: 1 + (len(bs) * len(ops)) // 1000]:
                want, got = ctypes.c_uint8(0), ctypes.c_uint8(0)
                assert m16(a, b, s, ctypes.byref(got)) == rs(a, b, s, ctypes.byref(want)), (a, b, s)
                assert got.value == want.value, (a, b, s)


def test_fx_umul16_q15_gives_the_bits_of_fx_mul16(native_lib) -> None:  # noqa: ANN001
    """The magnitude kernel (a < 2^31, b <= 2^15) against fx_mul16 at shift 15, on the edges
    and random operands: the same bits, and never past int32."""
    m16 = native_lib.fx_mul16_c
    m16.argtypes = [ctypes.c_int32, ctypes.c_int16, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint8)]
    m16.restype = ctypes.c_int32
    um = native_lib.fx_umul16_q15_c
    um.argtypes, um.restype = [ctypes.c_uint32, ctypes.c_uint16], ctypes.c_uint32
    rng = np.random.default_rng(15)
    edges = [0, 1, 2**15 - 1, 2**15, 2**16 - 1, 2**16, 2**31 - 2**15, 2**31 - 1]
    ays = edges + [int(a) for a in rng.integers(0, 2**31, 400)]
    bs = [0, 1, 2**14, 2**15 - 1] + [int(b) for b in rng.integers(0, 2**15, 100)]
    for a in ays:
        for b in bs:
            status = ctypes.c_uint8(0)
            assert um(a, b) == m16(a, b, 15, ctypes.byref(status)), (a, b)
            assert status.value == 0, (a, b)
    for a in ays:  # b = 2^15 (not an int16): the product is a itself
        assert um(a, 2**15) == a, a


def test_a_16_bit_factor_multiplies_rounded_half_up(native_lib) -> None:  # noqa: ANN001
    """fx_ufactor keeps a constant 0 <= x < 1 to 16 bits (m in [2^15, 2^16), relative error
    <= 2^-16, 16 <= sh <= 47) and fx_umul_f gives round(a m 2^-sh) half up for a < 2^31 (the
    AVR's assembly kernel is held to these bits by MANF FIXED's bit-exact drives)."""

    class Factor(ctypes.Structure):
        _fields_ = [("m", ctypes.c_uint16), ("sh", ctypes.c_uint8)]

    fac = native_lib.fx_ufactor
    fac.argtypes, fac.restype = [ctypes.c_uint32, ctypes.c_uint8], Factor
    mul = native_lib.fx_umul_f_c
    mul.argtypes = [ctypes.c_uint32, ctypes.c_uint16, ctypes.c_uint8]
    mul.restype = ctypes.c_uint32
    rng = np.random.default_rng(16)
    xs = [1, 2, 2**15, 2**29, 2**30 - 1, 10737418, 1073742]
    xs += [int(x) for x in rng.integers(1, 2**30, 300)]
    for x in xs:
        f = fac(x, 30)
        assert 2**15 <= f.m < 2**16 and 16 <= f.sh <= 47, x
        assert abs(f.m * 2.0**-f.sh - x * 2.0**-30) <= x * 2.0**-30 * 2.0**-16, x
    assert (fac(0, 30).m, fac(0, 30).sh) == (0, 16)
    ays = [0, 1, 2**15, 2**16 - 1, 2**24, 2**31 - 1] + [int(a) for a in rng.integers(0, 2**31, 200)]
    ms = [0, 1, 2**15, 2**16 - 1] + [int(m) for m in rng.integers(2**15, 2**16, 20)]
    for sh in [16, 17, 22, 24, 25, 33, 40, 47]:
        for a in ays:
            for m in ms:
                assert mul(a, m, sh) == (a * m + (1 << (sh - 1))) >> sh, (a, m, sh)


def test_a_signed_operand_times_a_16_bit_factor_rounds_half_up(native_lib) -> None:  # noqa: ANN001
    """fx_smul_f: round(a m 2^-sh) half up (floor of a m + 2^(sh-1)) for any int32 a, at
    every shift fx_ufactor gives, edge and random operands."""
    mul = native_lib.fx_smul_f_c
    mul.argtypes = [ctypes.c_int32, ctypes.c_uint16, ctypes.c_uint8]
    mul.restype = ctypes.c_int32
    rng = np.random.default_rng(17)
    ays = [0, 1, -1, 2**15, -(2**15), 2**16 - 1, -(2**16), 2**31 - 1, -(2**31)]
    ays += [int(a) for a in rng.integers(-(2**31), 2**31, 200)]
    ms = [0, 1, 2**15, 2**16 - 1] + [int(m) for m in rng.integers(2**15, 2**16, 20)]
    for sh in [16, 17, 18, 22, 24, 25, 32, 33, 40, 47]:
        for a in ays:
            for m in ms:
                assert mul(a, m, sh) == (a * m + (1 << (sh - 1))) >> sh, (a, m, sh)


def test_a_16_bit_reciprocal_keeps_its_stated_error(native_lib) -> None:  # noqa: ANN001
    """fx_recip16(b) = r 2^(n - 46) with r in [2^15, 2^16), within 5e-5 of 1/b for b over
    the whole positive int32 range, the table's nodes and their neighbours included."""

    class Recip16(ctypes.Structure):
        _fields_ = (("r", ctypes.c_uint16), ("n", ctypes.c_uint8))

    recip = native_lib.fx_recip16
    recip.argtypes, recip.restype = [ctypes.c_int32], Recip16
    rng = np.random.default_rng(46)
    nodes = [(2**30 + k * 2**25) >> s for k in range(32) for s in (0, 7, 20)]
    bs = [1, 2, 3, 2**31 - 1, 2**30, 2**30 - 1, 2**30 + 1] + nodes + [n + 1 for n in nodes]
    bs += [int(b) for b in rng.integers(1, 2**31, 2000)]
    worst = 0.0
    for b in bs:
        got = recip(b)
        assert 2**15 <= got.r < 2**16, b
        worst = max(worst, abs(got.r * 2.0 ** (got.n - 46) * b - 1.0))
    assert worst < 5e-5


def test_division_through_a_reciprocal_keeps_its_stated_error(native_lib) -> None:  # noqa: ANN001
    """fx_recip and fx_div_by (k = a / b as ACC's gains take it: Q28 / Q24 -> Q30) against
    exact quotients: relative error < 5e-7, or under one unit for small results; saturated
    past int32, flagged."""

    class Recip(ctypes.Structure):
        _fields_ = (("y", ctypes.c_int32), ("n", ctypes.c_uint8))

    recip, div = native_lib.fx_recip, native_lib.fx_div_by
    recip.argtypes, recip.restype = [ctypes.c_int32], Recip
    div.argtypes = [ctypes.c_int32, ctypes.c_uint8, Recip, ctypes.c_uint8, ctypes.c_uint8]
    div.argtypes += [ctypes.POINTER(ctypes.c_uint8)]
    div.restype = ctypes.c_int32
    rng = np.random.default_rng(7)
    bs = [1, 2, 3, 2**30, 2**31 - 1] + [
        int(rng.integers(1, 2 ** int(k))) for k in rng.integers(1, 32, 2000)
    ]
    for b in bs:
        r = recip(b)
        for a in (
            0,
            1,
            -1,
            2**31 - 1,
            -(2**31),
            int(rng.integers(-(2**31), 2**31)) >> int(rng.integers(0, 31)),
        ):
            status = ctypes.c_uint8(0)
            got = div(a, 28, r, 24, 30, ctypes.byref(status))
            exact = a * 2**26 / b
            if abs(exact) < 2**31 - 1:
                assert abs(got - exact) <= max(1.0, 5e-7 * abs(exact)), (a, b)
                assert status.value == 0
            else:
                assert got == (2**31 - 1 if exact > 0 else -(2**31)) and status.value & 0x01


def _fx_div_exact(a: int, qa: int, b: int, qb: int, q_out: int) -> tuple[int, int]:
    """fx_div's contract in Python's integers: |a| 2^up rounded (ties away from zero when
    up < 0), then the magnitude's quotient rounded half up, signed, saturated."""
    up = q_out + qb - qa
    if up >= 0:
        num = a << up
    else:
        m = (abs(a) + (1 << (-up - 1))) >> -up
        num = -m if a < 0 else m
    q = (abs(num) + abs(b) // 2) // abs(b)
    negative = (num < 0) != (b < 0)
    if q > 2**31 - 1 + negative:
        return (-(2**31) if negative else 2**31 - 1), 0x01
    return (-q if negative else q), 0


def test_fx_div_rounds_the_exact_quotient_half_up_and_saturates(native_lib) -> None:  # noqa: ANN001
    """Both of its ways: the 32-bit restoring division where |a| < |b| and the shift up
    is at most 30 (longit's grade ratio, Q16 / Q16 -> Q30), the 64-bit one elsewhere."""
    f = native_lib.fx_div
    f.argtypes = [ctypes.c_int32, ctypes.c_uint8, ctypes.c_int32, ctypes.c_uint8, ctypes.c_uint8]
    f.argtypes += [ctypes.POINTER(ctypes.c_uint8)]
    f.restype = ctypes.c_int32
    rng = np.random.default_rng(11)
    edges = [0, 1, -1, 2, 3, 2**30, 2**31 - 1, -(2**31), -(2**31) + 1]
    cases = [(a, 16, b, 16, 30) for a in edges for b in edges if b != 0]
    for _ in range(20_000):
        a = int(rng.integers(-(2**31), 2**31)) >> int(rng.integers(0, 31))
        b = int(rng.integers(-(2**31), 2**31)) >> int(rng.integers(0, 31))
        qa, qb, q_out = (int(q) for q in rng.integers(0, 31, 3))
        if b != 0 and q_out + qb - qa <= 31:
            cases.append((a, qa, b, qb, q_out))
    assert sum(abs(a) < abs(b) and 0 <= qo + qb - qa <= 30 for a, qa, b, qb, qo in cases) > 5000
    for a, qa, b, qb, q_out in cases:
        status = ctypes.c_uint8(0)
        got = f(a, qa, b, qb, q_out, ctypes.byref(status))
        assert (got, status.value) == _fx_div_exact(a, qa, b, qb, q_out), (a, qa, b, qb, q_out)
    status = ctypes.c_uint8(0)
    assert f(5, 0, 0, 0, 0, ctypes.byref(status)) == 2**31 - 1 and status.value & 0x04


def test_fx_dot16_sums_int16_products_modulo_2_to_the_32(native_lib) -> None:  # noqa: ANN001
    """The int16 dot product (the AVR's assembly loop has this C twin) against Python's
    integers, on the edges (-2^15 squared) and random operands, wrapping like int32."""
    f = native_lib.fx_dot16_c
    f.argtypes = [ctypes.POINTER(ctypes.c_int16), ctypes.POINTER(ctypes.c_int16), ctypes.c_uint8]
    f.restype = ctypes.c_int32
    rng = np.random.default_rng(17)
    cases = [([-(2**15)] * 9, [-(2**15)] * 9), ([2**15 - 1] * 3, [-(2**15)] * 3), ([], [])]
    for _ in range(2000):
        n = int(rng.integers(0, 12))
        cases.append(
            (
                [int(v) for v in rng.integers(-(2**15), 2**15, n)],
                [int(v) for v in rng.integers(-(2**15), 2**15, n)],
            )
        )
    for a, b in cases:
        want = sum(x * y for x, y in zip(a, b, strict=True)) % 2**32
        want -= 2**32 if want >= 2**31 else 0
        arr = ctypes.c_int16 * max(1, len(a))
        assert f(arr(*a), arr(*b), len(a)) == want, (a, b)


def test_fx_mul16_h15_gives_the_bits_of_fx_mul_shr(native_lib) -> None:  # noqa: ANN001
    """int32 × Q15 (|b| < 2^15), rounded half up, against fx_mul_shr at shift 15."""
    shr = _kernel(native_lib, "fx_mul_shr_c")
    m = native_lib.fx_mul16_h15_c
    m.argtypes, m.restype = [ctypes.c_int32, ctypes.c_int16], ctypes.c_int32
    rng = np.random.default_rng(1515)
    bs = [0, 1, -1, 2**14, 2**15 - 1, -(2**15) + 1] + [
        int(b) for b in rng.integers(-32767, 32768, 300)
    ]
    for a in _operands(rng, 300):
        for b in bs[:: 1 + len(bs) // 60]:
            status = ctypes.c_uint8(0)
            assert m(a, b) == shr(a, b, 15, ctypes.byref(status)), (a, b)
            assert status.value == 0, (a, b)


def test_fx_dot16x32_q15_rounds_the_exact_sum_once_and_saturates(native_lib) -> None:  # noqa: ANN001
    """The int16 × int32 dot product (strided int16s, as a Cholesky's column) against
    Python's integers: the exact sum rounded half up at 2^-15, saturated and flagged."""
    f = native_lib.fx_dot16x32_q15_c
    f.argtypes = [
        ctypes.POINTER(ctypes.c_int16),
        ctypes.POINTER(ctypes.c_int32),
        ctypes.c_uint8,
        ctypes.c_uint8,
        ctypes.POINTER(ctypes.c_uint8),
    ]
    f.restype = ctypes.c_int32
    rng = np.random.default_rng(1632)
    edge_l, edge_y = [-(2**15), 2**15 - 1, -1, 1], [-(2**31), 2**31 - 1, -1, 1]
    for _ in range(3000):
        n, stride = int(rng.integers(0, 7)), int(rng.integers(1, 7))
        ls = [
            int(v) for v in rng.choice(edge_l + list(rng.integers(-(2**15), 2**15, 4)), n * stride)
        ]
        ys = [int(v) for v in rng.choice(edge_y + list(rng.integers(-(2**31), 2**31, 4)), n)]
        exact = sum(ls[k * stride] * ys[k] for k in range(n))
        want = (exact + 2**14) >> 15
        status = ctypes.c_uint8(0)
        got = f(
            (ctypes.c_int16 * max(1, len(ls)))(*ls),
            (ctypes.c_int32 * max(1, n))(*ys),
            n,
            stride,
            ctypes.byref(status),
        )
        assert got == max(-(2**31), min(2**31 - 1, want)), (ls, ys, stride)
        assert bool(status.value & 1) == (not -(2**31) <= want < 2**31), (ls, ys, stride)


def test_a_signed_factor_multiplies_rounded_ties_away_and_saturates(native_lib) -> None:  # noqa: ANN001
    """fx_factor keeps x 2^e to 16 bits (m in [2^15, 2^16), 9 <= sh <= 47, the sign in sh's
    bit 7; past 128: saturated and flagged) and fx_mul_f_c gives round(a f), ties away from
    zero, saturated and flagged, against Python's integers on edges and random operands (the
    AVR's assembly kernel, fx_mul_f_avr.S, is held to these bits by the ESO's bit-exact
    drives)."""

    class Factor(ctypes.Structure):
        _fields_ = [("m", ctypes.c_uint16), ("sh", ctypes.c_uint8)]

    fac = native_lib.fx_factor
    fac.argtypes = [ctypes.c_float, ctypes.c_int8, ctypes.POINTER(ctypes.c_uint8)]
    fac.restype = Factor
    mul = native_lib.fx_mul_f_c
    mul.argtypes = [ctypes.c_int32, ctypes.c_uint16, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint8)]
    mul.restype = ctypes.c_int32
    rng = np.random.default_rng(1717)
    for x, e in [(0.978, 5), (-1.82, 0), (9.87e-6, 0), (-282.5, -12), (3.2e-4, 8), (127.9, 0)]:
        st = ctypes.c_uint8(0)
        f = fac(x, e, ctypes.byref(st))
        value = (-1 if f.sh & 0x80 else 1) * f.m * 2.0 ** -(f.sh & 0x3F)
        assert 2**15 <= f.m < 2**16 and 9 <= f.sh & 0x3F <= 47 and st.value == 0, (x, e)
        assert abs(value - x * 2.0**e) <= abs(x * 2.0**e) * 2.0**-16, (x, e)
    st = ctypes.c_uint8(0)
    assert fac(128.0, 0, ctypes.byref(st)).m == 0xFFFF and st.value & 0x01
    assert fac(0.0, 0, ctypes.byref(st)).m == 0
    edges = [0, 1, -1, 2**31 - 1, -(2**31), 2**30, -(2**30) - 1]
    ays = edges + [int(a) >> int(rng.integers(0, 31)) for a in rng.integers(-(2**31), 2**31, 300)]
    ms = [0, 1, 2**15, 2**16 - 1] + [int(m) for m in rng.integers(2**15, 2**16, 12)]
    for sh in [9, 10, 15, 16, 17, 23, 24, 31, 32, 40, 47]:
        for neg in (0, 0x80):
            for a in ays:
                for m in ms:
                    mag = (abs(a) * m + (1 << (sh - 1))) >> sh
                    want = -mag if (a < 0) != bool(neg) else mag
                    st = ctypes.c_uint8(0)
                    got = mul(a, m, sh | neg, ctypes.byref(st))
                    assert got == max(-(2**31), min(2**31 - 1, want)), (a, m, sh, neg)
                    assert bool(st.value & 1) == (not -(2**31) <= want < 2**31), (a, m, sh, neg)


def test_fx_umul_q24_rounds_half_up_below_2_31(native_lib) -> None:  # noqa: ANN001
    """a b 2^-24 rounded half up for a < 2^31 and a Q24 factor b < 2^24 (the AVR's 32 x 24
    product is held to these bits by tests/hil/test_fixmath_kernels_hil.py)."""
    f = native_lib.fx_umul_q24_c
    f.argtypes, f.restype = [ctypes.c_uint32, ctypes.c_uint32], ctypes.c_uint32
    rng = np.random.default_rng(24)
    ays = [0, 1, 2**23, 2**24 - 1, 2**31 - 1] + [int(a) for a in rng.integers(0, 2**31, 300)]
    bs = [0, 1, 2**23, 2**24 - 1] + [int(b) for b in rng.integers(0, 2**24, 100)]
    for a in ays:
        for b in bs:
            assert f(a, b) == (a * b + 2**23) >> 24, (a, b)
    assert f(2**31 - 1, 2**24 - 1) < 2**31


def test_fx_mul_q24_rs16_gives_the_bits_of_fx_mul(native_lib) -> None:  # noqa: ANN001
    """a b 2^-16 for a Q24 factor 0 <= b < 2^24: fx_mul_rs's rounding (ties away from
    zero) and saturation, flagged, for every int32 a."""
    rs = native_lib.fx_mul_rs_c
    rs.argtypes = [ctypes.c_int32, ctypes.c_int32, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint8)]
    rs.restype = ctypes.c_int32
    f = native_lib.fx_mul_q24_rs16_c
    f.argtypes = [ctypes.c_int32, ctypes.c_uint32, ctypes.POINTER(ctypes.c_uint8)]
    f.restype = ctypes.c_int32
    rng = np.random.default_rng(25)
    ays = [0, 1, -1, 2**15, -(2**15), 2**31 - 1, -(2**31), -(2**31) + 1]
    ays += [int(a) for a in rng.integers(-(2**31), 2**31, 300)]
    bs = [0, 1, 2**15, 2**16, 2**24 - 1] + [int(b) for b in rng.integers(0, 2**24, 100)]
    saturated = 0
    for a in ays:
        for b in bs:
            want, got = ctypes.c_uint8(0), ctypes.c_uint8(0)
            assert f(a, b, ctypes.byref(got)) == rs(a, b, 16, ctypes.byref(want)), (a, b)
            assert got.value == want.value, (a, b)
            saturated += got.value
    assert saturated > 0
    exact = [(a * b + 2**15 - (a < 0)) >> 16 for a, b in [(-(2**31), 2**16), (-3, 2**15)]]
    status = ctypes.c_uint8(0)
    assert [f(-(2**31), 2**16, ctypes.byref(status)), f(-3, 2**15, ctypes.byref(status))] == exact
    assert status.value == 0  # INT32_MIN itself is in range


def test_fx_rescale_rounds_ties_away_from_zero(native_lib) -> None:  # noqa: ANN001
    """Down by d bits: floor(a 2^-d + 1/2) for a >= 0, ceil(a 2^-d - 1/2) below, for every
    d (the 16-bit path up to 15, 32-bit past it)."""
    f = native_lib.fx_rescale_c
    f.argtypes = [ctypes.c_int32, ctypes.c_uint8, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint8)]
    f.restype = ctypes.c_int32
    rng = np.random.default_rng(26)
    ays = [0, 1, -1, 2**31 - 1, -(2**31)] + [int(a) for a in rng.integers(-(2**31), 2**31, 400)]
    for d in range(1, 32):
        half = 1 << (d - 1)
        for a in ays + [half, -half, 3 * half, -3 * half, 2**31 - half, -(2**31) + half]:
            a = max(min(a, 2**31 - 1), -(2**31))
            want = (a + half) >> d if a >= 0 else -((-a + half) >> d)
            status = ctypes.c_uint8(0)
            assert f(a, 31, 31 - d, ctypes.byref(status)) == want, (a, d)
            assert status.value == 0


def test_fx_tanh_abs_q15_by_bytes_gives_the_tables_bits(native_lib) -> None:  # noqa: ANN001
    """|x| in Q20..Q27 takes the cell and fraction by bytes: the same bits as the table's
    interpolation at |x| >> (qx - 19)."""
    pos = native_lib.fx_tanh_q15_pos
    pos.argtypes, pos.restype = [ctypes.c_uint32], ctypes.c_uint16
    f = native_lib.fx_tanh_abs_q15_c
    f.argtypes, f.restype = [ctypes.c_uint32, ctypes.c_uint8], ctypes.c_uint16
    rng = np.random.default_rng(27)
    for qx in range(20, 28):
        top = 64 << (qx - 4)
        for mag in [0, 1, top - 1, top, top + 1, 2**32 - 1] + [
            int(m) for m in rng.integers(0, top, 500)
        ]:
            want = 32746 if mag >= top else pos(mag >> (qx - 19))
            assert f(mag, qx) == want, (mag, qx)
