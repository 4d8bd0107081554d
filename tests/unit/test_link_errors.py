"""The link's and the boards' errors: what a user is told, and nothing more."""

import os

import pytest
import serial

from vehil.errors import BoardTimeout
from vehil.link import Link


def test_a_board_that_never_answers_is_named_with_the_tries_and_time_spent() -> None:
    host, board = os.openpty()  # a port whose far end reads nothing and answers nothing
    port = serial.Serial(os.ttyname(board), timeout=0.01)
    try:
        link = Link(port, timeout_s=0.05, retries=2)
        with pytest.raises(BoardTimeout) as exc:
            link.request("CONFIG", estimator=0, mode=0, offset=0, params=b"\0" * 40)
    finally:
        port.close()
        os.close(host)
        os.close(board)
    said = str(exc.value)
    assert said.startswith("no reply to CONFIG (not sent again: the copies sent before, unanswered")
    assert "a board slower to answer needs a longer --timeout" in said
    assert ", the last of 3 tries over" in said


@pytest.mark.parametrize(
    ("args", "error"),
    [
        (["ping", "--count", "0"], "argument --count: 0: give a number above 0"),
        (["ping", "--count", "1.5"], "argument --count: '1.5' is not a whole number"),
        (["ping", "--window", "-1"], "argument --window: -1: give a number above 0"),
        (["run", "sine", "--timeout", "0"], "argument --timeout: 0: give a number above 0"),
        (["info", "--timeout", "soon"], "argument --timeout: 'soon' is not a number"),
    ],
)
def test_counts_windows_and_timeouts_below_one_are_refused_by_name(args, error, capsys) -> None:  # noqa: ANN001
    from vehil import cli

    with pytest.raises(SystemExit) as exc:
        cli.main(args)
    assert exc.value.code == 2 and error in capsys.readouterr().err


def test_an_unreachable_labgrid_coordinator_is_said_once(monkeypatch, capsys, caplog) -> None:  # noqa: ANN001
    import socket

    from vehil import cli

    with socket.socket() as s:  # a port with nothing listening
        s.bind(("127.0.0.1", 0))
        address = f"127.0.0.1:{s.getsockname()[1]}"
    monkeypatch.setenv("LG_COORDINATOR", address)
    assert cli.main(["info", "--board", "labgrid:mega-3"]) == 2
    said = capsys.readouterr()
    assert f"cannot reach the labgrid coordinator at {address}" in said.out
    assert "coordinator is unavailable" not in said.err + caplog.text  # labgrid's own log line


def test_a_lost_sample_is_named_by_its_index_and_why_it_was_not_sent_again() -> None:
    from vehil.link import _Pending

    lost = _Pending("SAMPLE", (2584).to_bytes(2, "little") + b"\0" * 4)
    assert lost.describe() == (
        "SAMPLE (sample 2584; not sent again: the copies sent before, unanswered, may still "
        "fill the board's RX buffer)"
    )
    lost.seq = 7
    assert lost.describe() == "SAMPLE seq 7 (sample 2584)"


def test_a_serial_port_with_no_vehil_board_says_what_to_check(monkeypatch) -> None:  # noqa: ANN001
    from vehil.boards.base import BoardOptions
    from vehil.boards.serialport import SerialBoard

    host, board = os.openpty()  # a port nothing answers on
    name = os.ttyname(board)
    target = SerialBoard(name, BoardOptions(timeout_s=0.05))
    monkeypatch.setattr(target, "ready_timeout_s", 0.1)
    port = serial.Serial(name, timeout=0.01)
    try:
        with pytest.raises(BoardTimeout) as exc:
            target.wait_ready(Link(port, timeout_s=0.05, retries=0))
    finally:
        port.close()
        os.close(host)
        os.close(board)
    said = str(exc.value)
    assert said.startswith(f"{name}: no ready frame within 0 s after opening at 1000000 baud")
    assert "--baud switches it only once connected" in said and "vehil flash" in said
    assert "give --boot-baud if the board runs an image built with another" in said


def test_an_estimator_the_image_lacks_is_not_a_lost_board_and_says_where_it_is() -> None:
    from vehil.errors import LinkError, NotInImage
    from vehil.link import BoardInfo, EstimatorInfo

    info = BoardInfo({}, (EstimatorInfo(0, 20, "manf", ("F32",), 2, 2, 10),))
    with pytest.raises(NotInImage) as exc:
        info.estimator("ev_ekf")
    assert not isinstance(exc.value, LinkError)  # the runner reports no "board lost"
    said = str(exc.value)
    assert said.startswith("estimator 'ev_ekf' is not built into this firmware (built in: manf)")
    assert "simavr-ev and qemu-ev" in said
