"""`vehil flash` end to end: avrdude programs the firmware through the Mega's real
stk500v2 bootloader on simavr, and what runs afterwards is what it wrote."""

import dataclasses
import functools
import operator
import time
from pathlib import Path

import pytest
import serial
from rich.console import Console

from vehil import flash, runner, scenario
from vehil.boards import BoardOptions
from vehil.boards.simavr import SimavrBootloaderBoard
from vehil.cli import main
from vehil.errors import NoPort, VerifyMismatch, WrongSignature
from vehil.paths import MEGA_BOOTLOADER_HEX

pytestmark = [
    pytest.mark.hil,
    pytest.mark.skipif(
        not MEGA_BOOTLOADER_HEX.exists(), reason="needs Debian's arduino-core-avr (bootloader)"
    ),
]


Flashed = tuple[flash.FlashResult, Path, dict]


@pytest.fixture(scope="module")
def image(built, tmp_path_factory) -> Path:  # noqa: ANN001
    return flash.to_hex(built["firmware"], tmp_path_factory.mktemp("image") / "firmware.hex")


@pytest.fixture(scope="module")
def flashed_once(image: Path, tmp_path_factory) -> Flashed:  # noqa: ANN001
    """The firmware flashed through the bootloader, once for the module: what avrdude
    did, the flash image the board left, and the INFO the firmware then sent."""
    flash_bin = tmp_path_factory.mktemp("board") / "flash.bin"
    board = SimavrBootloaderBoard(BoardOptions(timeout_s=3.0), flash_image=flash_bin)
    with flash.flashed(board, image) as (result, link):
        assert link.info is not None
        return result, flash_bin, {"info": link.info}


def _flip_byte(src: Path, dst: Path, address: int) -> int:
    """Copies an Intel HEX file with the byte at `address` inverted; returns the original."""
    lines, base, original = [], 0, -1
    for line in src.read_text().split():
        rec = bytearray.fromhex(line[1:])
        if rec[3] == 2:  # extended segment address: objcopy's way past 64 KB
            base = int.from_bytes(rec[4:6], "big") << 4
        if rec[3] == 4:  # extended linear address
            base = int.from_bytes(rec[4:6], "big") << 16
        start = base + int.from_bytes(rec[1:3], "big")
        if rec[3] == 0 and start <= address < start + rec[0]:
            original = rec[4 + address - start]
            rec[4 + address - start] ^= 0xFF
            rec[-1] = -sum(rec[:-1]) & 0xFF
        lines.append(":" + rec.hex().upper())
    dst.write_text("\n".join(lines) + "\n")
    assert original >= 0, f"no data at 0x{address:x} in {src}"
    return original


def test_flash_through_the_bootloader_then_the_flashed_firmware_runs_a_scenario(
    flashed_once: Flashed, tmp_path: Path
) -> None:
    result, flash_bin, seen = flashed_once
    assert result.bytes > 40_000
    # avrdude's own timings are reported (their size is a benchmark's business: the host is shared)
    assert result.write_s > 0 and result.verify_s > 0
    assert seen["info"].f_cpu == 16_000_000
    assert "passthrough" in [e.name for e in seen["info"].estimators]
    # The flash outlives the bridge: a new one starts from it and runs 1,000 samples.
    written = flash_bin.read_bytes()
    boot = MEGA_BOOTLOADER_HEX.read_text()
    assert written[:4] != b"\xff\xff\xff\xff" and len(written) == 256 * 1024
    assert written[0x3E000:0x3E004].hex().upper() in boot
    sine = dataclasses.replace(scenario.load("sine"), duration=2.0)
    board = SimavrBootloaderBoard(BoardOptions(timeout_s=3.0), flash_image=flash_bin)
    run = runner.run(sine, board, recording=tmp_path / "run.arrow", console=Console(quiet=True))
    assert run.error is None and run.done == 1000
    assert run.figures.passed


@pytest.mark.long
def test_a_corrupted_image_fails_verification_naming_address_expected_and_got(
    image: Path, tmp_path: Path
) -> None:
    bad = tmp_path / "corrupted.hex"
    address = 0x1234
    original = _flip_byte(image, bad, address)
    board = SimavrBootloaderBoard(BoardOptions(timeout_s=3.0), flash_image=None)
    # Writes the corrupted image (which verifies against itself), then compares the
    # flash with the good one.
    with pytest.raises(VerifyMismatch) as caught, flash.flashed(board, bad, verify_with=image):
        pass
    err = caught.value
    assert (err.address, err.expected, err.got) == (address, original, original ^ 0xFF)
    assert f"0x{address:05x}" in str(err) and f"0x{original:02x}" in str(err)
    assert board.process is None  # stopped


def test_a_chip_that_is_not_the_part_is_refused_with_both_signatures(image: Path) -> None:
    board = SimavrBootloaderBoard(BoardOptions(timeout_s=3.0), flash_image=None)
    with pytest.raises(WrongSignature) as caught, flash.flashed(board, image, part="m1280"):
        pass
    assert (caught.value.expected, caught.value.got) == ("0x1e9703", "0x1e9801")


def test_the_cli_says_why_it_cannot_flash(image: Path, capsys) -> None:  # noqa: ANN001
    cases = [
        (["--board", "simavr"], "has no bootloader to program"),
        (["--port", "/dev/ttyNOPE"], "no serial port /dev/ttyNOPE"),
        (["--board", "simavr-bootloader", "--baud", "57600"], "115200 baud only"),
        ([], "give the board's port"),
    ]
    for options, says in cases:
        assert main(["flash", "--image", str(image), *options]) == 2
        assert says in " ".join(capsys.readouterr().out.split()), options


def test_avrdude_on_a_missing_port_is_stopped_at_once_with_the_reason(image: Path) -> None:
    # avrdude 7.1 would spin at 100 % CPU for good after failing to open the port.
    start = time.monotonic()
    with pytest.raises(NoPort, match="No such file"):
        flash.run_avrdude("/dev/ttyNOPE", image, timeout_s=20)
    assert time.monotonic() - start < 5


def _stk500v2(seq: int, body: bytes) -> bytes:
    msg = bytes([0x1B, seq, len(body) >> 8, len(body) & 0xFF, 0x0E]) + body
    return msg + bytes([functools.reduce(operator.xor, msg)])


def test_the_bootloader_waits_for_a_host_that_pauses_as_long_as_on_a_chip(
    flashed_once: Flashed,
) -> None:
    # Its timeout (~4.5 s at 16 MHz) would pass in ~0.4 s free-running: a host that
    # paused that long would meet the firmware instead. Sign on, pause, sign on again.
    _, flash_bin, _ = flashed_once
    board = SimavrBootloaderBoard(flash_image=flash_bin)
    try:
        port = serial.Serial(board.start(), 115200, timeout=1.0)
        for seq, pause in enumerate((0.1, 1.5)):
            time.sleep(pause)
            port.write(_stk500v2(seq, b"\x01"))  # CMD_SIGN_ON
            assert b"AVRISP_2" in port.read(19), f"no answer after {pause} s"
        port.close()
    finally:
        board.stop()
