"""What avrdude's output means: each failure becomes the error a user can act on.

The texts are avrdude's own (7.1 as Debian ships it, and 6.3 where it words things
differently); the simavr HIL tests produce the 7.1 ones for real."""

import pytest

from vehil import flash
from vehil.errors import (
    AvrdudeMissing,
    NoBootloader,
    NoPort,
    PortBusy,
    UnsupportedBaud,
    VerifyMismatch,
    WrongSignature,
)

PORT = "/dev/ttyACM0"


def test_a_mismatch_in_avrdude_7_wording_names_address_expected_and_got() -> None:
    out = (
        "avrdude warning: verification mismatch\n"
        "        device 0xb3 != input 0x4c at addr 0x1234 (error)\n"
        "avrdude error: verification mismatch\n"
    )
    err = flash.avrdude_error(out, PORT)
    assert isinstance(err, VerifyMismatch)
    assert (err.address, err.expected, err.got) == (0x1234, 0x4C, 0xB3)


def test_a_mismatch_in_avrdude_6_wording_names_address_expected_and_got() -> None:
    out = (
        "avrdude: verification error, first mismatch at byte 0x1f000\n"
        "         0x0c != 0xff\n"
        "avrdude: verification error; content mismatch\n"
    )
    err = flash.avrdude_error(out, PORT)
    assert isinstance(err, VerifyMismatch)
    assert (err.address, err.expected, err.got) == (0x1F000, 0x0C, 0xFF)
    assert "0x1f000" in str(err)


def test_an_uno_on_the_port_is_a_wrong_signature_in_either_wording() -> None:
    for out in (
        "avrdude: device signature = 0x1e950f (probably m328p)\n"
        "avrdude error: expected signature for ATmega2560 is 1E 98 01\n",
        "avrdude: Device signature = 0x1e950f (probably m328p)\n"
        "avrdude: Expected signature for ATmega2560 is 1E 98 01\n",
    ):
        err = flash.avrdude_error(out, PORT)
        assert isinstance(err, WrongSignature)
        assert (err.expected, err.got) == ("0x1e9801", "0x1e950f")


def test_port_missing_busy_and_silent_bootloader_say_what_to_do() -> None:
    for out in (
        "avrdude OS error: cannot open port /dev/ttyACM0: No such file or directory\n",
        'avrdude: ser_open(): can\'t open device "/dev/ttyACM0": No such file or directory\n',
    ):
        assert isinstance(flash.avrdude_error(out, PORT), NoPort)
    busy = flash.avrdude_error(
        'avrdude: ser_open(): can\'t open device "/dev/ttyACM0": Device or resource busy\n', PORT
    )
    assert isinstance(busy, PortBusy) and "ModemManager" in str(busy)
    silent = flash.avrdude_error(
        "avrdude: stk500v2_ReceiveMessage(): timeout\n"
        "avrdude: stk500v2_getsync(): timeout communicating with programmer\n",
        PORT,
    )
    assert isinstance(silent, NoBootloader)
    assert "115200" in str(silent) and "reset" in str(silent) and "CH340" in str(silent)


def test_a_baud_the_bootloader_cannot_do_is_refused_before_avrdude_runs(tmp_path) -> None:  # noqa: ANN001
    with pytest.raises(UnsupportedBaud, match="115200 baud only"):
        flash.run_avrdude(PORT, tmp_path / "x.hex", baud=57600)


def test_without_avrdude_the_error_names_the_debian_package(tmp_path, monkeypatch) -> None:  # noqa: ANN001
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(AvrdudeMissing, match="apt-get install avrdude"):
        flash.run_avrdude(PORT, tmp_path / "x.hex")


def test_avrdude_reaches_sockets_but_not_other_urls() -> None:
    assert flash.avrdude_port("socket://127.0.0.1:4000") == "net:127.0.0.1:4000"
    assert flash.avrdude_port(PORT) == PORT
    with pytest.raises(flash.FlashError):
        flash.avrdude_port("native://")


@pytest.mark.parametrize(
    ("args", "error"),
    [
        (["--port", "/dev/ttyNOSUCH9"], "no serial port /dev/ttyNOSUCH9; ports seen:"),
        (["--port", "/dev/ttyNOSUCH9", "--baud", "57600"], "115200 baud only"),
        (["--board", "qemu"], "the qemu board has no bootloader to program"),
    ],
)
def test_vehil_flash_refuses_a_bad_target_before_building_an_image(
    args,  # noqa: ANN001
    error,  # noqa: ANN001
    monkeypatch,  # noqa: ANN001
    capsys,  # noqa: ANN001
) -> None:
    from vehil import cli

    def build(*_: object) -> None:
        raise AssertionError("an image was built for a target that cannot take it")

    monkeypatch.setattr(flash, "firmware_hex", build)
    assert cli.main(["flash", *args]) == 2
    assert error in " ".join(capsys.readouterr().out.split())


def test_vehil_flash_to_a_labgrid_place_finds_the_coordinator_down_before_building(
    monkeypatch,  # noqa: ANN001
    capsys,  # noqa: ANN001
) -> None:
    from vehil import cli

    coordinator = "127.0.0.1:9"  # the discard port: nothing listens there

    def build(*_: object) -> None:
        raise AssertionError("an image was built for a place whose coordinator is down")

    monkeypatch.setattr(flash, "firmware_hex", build)
    monkeypatch.setenv("LG_COORDINATOR", coordinator)
    assert cli.main(["flash", "--board", "labgrid:mega-a"]) == 2
    said = " ".join(capsys.readouterr().out.split())
    assert f"cannot reach the labgrid coordinator at {coordinator}" in said
