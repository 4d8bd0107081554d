"""A firmware built to boot at 115200 baud (`vehil build --boot-baud`), for USB-serial
adapters that cannot run 1 Mbaud: its UART runs at that rate from reset, the image says
so, and the host opens the link at it, on simavr's chip-timed UART."""

from pathlib import Path

import numpy as np
import pytest

from vehil.boards import BoardOptions, SimavrBoard
from vehil.boards.base import image_boot_baud
from vehil.build.platformio import build_image
from vehil.errors import BuildError
from vehil.paths import FIRMWARE_ELF
from vehil.ping import run_ping

pytestmark = pytest.mark.hil


@pytest.fixture(scope="module")
def slow_boot(built) -> Path:  # noqa: ANN001
    return build_image("passthrough", boot_baud=115200)


def board_on(elf: Path, **options: int) -> SimavrBoard:
    board = SimavrBoard(BoardOptions(timeout_s=3.0, **options))
    board.elf = elf
    return board


def test_an_image_built_to_boot_at_115200_is_reached_at_115200_and_switches_up(
    slow_boot: Path,
) -> None:
    assert image_boot_baud(slow_boot) == 115200
    assert image_boot_baud(FIRMWARE_ELF) == 1_000_000  # the default image is left as it was
    board = board_on(slow_boot)
    assert board.baud == 115200  # the link opens at the image's rate, unasked
    with board.session() as link:
        assert link.info is not None and link.info.fields["baud"] == 115200
        booted = run_ping(link, count=40, size=16, window=8)
        link.set_baud(500_000)
        switched = run_ping(link, count=40, size=16, window=8)
    # streamed, the PONGs leave at the line's pace: 500,000 / 117,647 (115,200 + 2.1 %, as
    # UBRR0 makes it) apart, where a UART left at 1 Mbaud would pace both alike
    ratio = np.median(booted.board_interval_s) / np.median(switched.board_interval_s)
    assert ratio == pytest.approx(500_000 / 117_647, rel=0.02)


def test_the_board_options_boot_rate_wins_over_the_image_s(slow_boot: Path) -> None:
    with board_on(slow_boot, baud=500_000).session() as link:
        assert link.info is not None and link.info.fields["baud"] == 500_000
    assert board_on(FIRMWARE_ELF, boot_baud=115200).baud == 115200


def test_a_boot_rate_the_uart_cannot_make_is_refused_before_building() -> None:
    with pytest.raises(BuildError, match=r"--boot-baud 300: below 489 baud, the slowest"):
        build_image("passthrough", boot_baud=300)
    with pytest.raises(
        BuildError, match=r"--boot-baud 300000: the UART makes 285,714 \(-4\.8 %\), past"
    ):
        build_image("passthrough", boot_baud=300_000)


def test_vehil_run_runs_at_the_baud_it_is_given(built, tmp_path: Path) -> None:  # noqa: ANN001
    from vehil import cli, record
    from vehil.paths import DATA_ROOT

    sine = (DATA_ROOT / "scenarios/synthetic/sine.toml").read_text()
    short = tmp_path / "sine.toml"
    short.write_text(sine.replace("duration = 20.0", "duration = 0.2"))
    out = tmp_path / "run"
    assert (
        cli.main(["run", str(short), "--board", "simavr", "--baud", "500000", "--out", str(out)])
        == 0
    )
    assert record.read(out / "run.arrow").header["board"]["info"]["baud"] == 500_000
