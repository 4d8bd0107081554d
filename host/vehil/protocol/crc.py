"""CRC-32C (Castagnoli: reflected polynomial 0x82F63B78, init and final xor 0xFFFFFFFF),
table-driven like firmware/lib/proto/crc32c.c."""

from __future__ import annotations

INIT = 0xFFFFFFFF
POLY = 0x82F63B78


def _table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ POLY if crc & 1 else crc >> 1
        table.append(crc)
    return table


TABLE = _table()


def crc32c(data: bytes, crc: int = INIT) -> int:
    """The CRC register after `data` (no final xor): chain calls, then xor with INIT."""
    for byte in data:
        crc = TABLE[(crc ^ byte) & 0xFF] ^ (crc >> 8)
    return crc
