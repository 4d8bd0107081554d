"""tcp:// keeps what a board sends while the port opens (QEMU's boot INFO); socket://,
which it is built on, throws that away."""

from __future__ import annotations

import select
import socket
import threading
import time

import pytest
import serial
from serial.urlhandler import protocol_socket

import vehil.transports  # noqa: F401  (registers tcp://)

BOOT = b"\x03ab\x00"


@pytest.fixture
def talking_peer(monkeypatch: pytest.MonkeyPatch):  # noqa: ANN201
    """A peer that sends BOOT the moment it accepts, and a connect that returns only once
    those bytes have arrived: the race a loaded host loses, made certain. The peer keeps
    the connection open until the test is done."""
    server = socket.create_server(("127.0.0.1", 0))
    done = threading.Event()

    def serve() -> None:
        conn, _ = server.accept()
        conn.sendall(BOOT)
        done.wait()
        conn.close()

    threading.Thread(target=serve, daemon=True).start()
    connect = socket.create_connection

    def connect_then_wait(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        s = connect(*args, **kwargs)
        # waited for, not slept on: a loaded host can keep the peer from sending for 0.2 s
        assert select.select([s], [], [], 30)[0], "the peer sent nothing"
        return s

    monkeypatch.setattr(protocol_socket.socket, "create_connection", connect_then_wait)
    yield server.getsockname()[1]
    done.set()
    server.close()


def test_tcp_keeps_the_bytes_that_arrive_while_it_opens(talking_peer: int) -> None:
    with serial.serial_for_url(f"tcp://127.0.0.1:{talking_peer}", timeout=0.5) as port:
        assert port.read(len(BOOT)) == BOOT


def test_socket_loses_them_which_is_why_qemu_uses_tcp(talking_peer: int) -> None:
    with serial.serial_for_url(f"socket://127.0.0.1:{talking_peer}", timeout=0.3) as port:
        assert port.read(len(BOOT)) == b""


def test_tcp_refuses_another_scheme() -> None:
    from vehil.transports.protocol_tcp import Serial

    with pytest.raises(serial.SerialException, match="tcp://HOST:PORT"):
        Serial().from_url("socket://127.0.0.1:1")


def test_read_waiting_hands_over_all_that_has_arrived_and_says_when_the_peer_is_gone() -> None:
    server = socket.create_server(("127.0.0.1", 0))
    with serial.serial_for_url(f"tcp://127.0.0.1:{server.getsockname()[1]}", timeout=0.2) as port:
        conn, _ = server.accept()
        assert port.read_waiting() == b""  # nothing within the timeout
        conn.sendall(b"\x03ab\x00\x02c\x00")
        time.sleep(0.05)
        assert port.read_waiting() == b"\x03ab\x00\x02c\x00"  # both frames, in one call
        conn.close()
        with pytest.raises(serial.SerialException, match="disconnected"):
            port.read_waiting()
    server.close()
