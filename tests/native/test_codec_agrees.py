"""The C codec (firmware/lib/proto, host build) and the Python codec agree."""

import ctypes

from hypothesis import given, settings
from hypothesis import strategies as st

from vehil.protocol import cobs, frame
from vehil.protocol.crc import crc16
from vehil.protocol.schema import SCHEMA


def _buf(n: int) -> ctypes.Array:
    return ctypes.create_string_buffer(n)


@settings(max_examples=300)
@given(data=st.binary(max_size=600))
def test_c_cobs_encode_equals_python(native_lib, data: bytes) -> None:
    out = _buf(len(data) + len(data) // 254 + 2)
    n = native_lib.cobs_encode(data, len(data), out)
    assert out.raw[:n] == cobs.encode(data)


@settings(max_examples=300)
@given(block=st.binary(max_size=300))
def test_c_cobs_decode_accepts_and_refuses_what_python_does(native_lib, block: bytes) -> None:
    native_lib.cobs_decode.restype = ctypes.c_int16
    out = _buf(len(block) + 1)
    n = native_lib.cobs_decode(block, len(block), out)
    try:
        expected = cobs.decode(block)
    except cobs.CobsError:
        assert n == -1
    else:
        assert out.raw[:n] == expected


@given(data=st.binary(max_size=300))
def test_c_crc_equals_python(native_lib, data: bytes) -> None:
    native_lib.crc16.restype = ctypes.c_uint16
    assert native_lib.crc16(data, len(data)) == crc16(data)


@settings(max_examples=300)
@given(
    type_code=st.integers(0, 255),
    seq=st.integers(0, 255),
    body=st.binary(max_size=SCHEMA.max_body),
)
def test_c_frame_encode_equals_python(native_lib, type_code: int, seq: int, body: bytes) -> None:
    native_lib.frame_encode.restype = ctypes.c_uint16
    out = _buf(frame.WIRE_MAX)
    n = native_lib.frame_encode(type_code, seq, body, len(body), out)
    assert out.raw[:n] == frame.encode(type_code, seq, body)
