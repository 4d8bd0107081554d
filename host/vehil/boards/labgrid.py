"""A board on a labgrid place (`--board labgrid:PLACE`, or `labgrid:ENV.yaml`): acquired
through the labgrid coordinator, reached through the place's NetworkSerialPort (RFC 2217,
served by the exporter's ser2net), released however the session ends. See docs/labgrid.md.

labgrid's client runs on asyncio; it gets an event loop of its own in a thread, so the
place's state keeps arriving while the run streams, and a place released by someone else
mid-run closes the port at once (a clear error, not a run on a board that is not ours).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import getpass
import json
import logging
import os
import socket
import threading
import time
from collections.abc import Callable, Coroutine, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import serial

from vehil.boards.base import BoardOptions
from vehil.boards.serialport import SerialBoard
from vehil.errors import BoardStartError, NoPort
from vehil.paths import runs_dir

DEFAULT_COORDINATOR = "127.0.0.1:20408"  # labgrid's own default
_POLL_S = 0.2
_CALL_TIMEOUT_S = 10.0
_NEWS_WAIT_S = 2.0


def _quiet(record: logging.LogRecord) -> bool:
    """labgrid's client logs a refused connection through the root logger, which prints it
    as `ERROR:root:...` above the error vehil raises for the same failure."""
    return False


@dataclass(frozen=True, kw_only=True)
class LabgridOptions:
    coordinator: str = field(
        default_factory=lambda: os.environ.get("LG_COORDINATOR", DEFAULT_COORDINATOR)
    )
    wait_s: float = 60.0  # how long to wait for a place someone else holds
    usage_log: Path | None = None  # one JSON line per use; None: <runs>/labgrid-usage.jsonl


def place_of(target: str) -> tuple[str, str | None]:
    """The place a `labgrid:` target names, and the coordinator an environment file gives."""
    if not target.endswith((".yaml", ".yml")):
        return target, None
    from labgrid import Environment
    from labgrid.factory import target_factory

    if not Path(target).is_file():
        raise NoPort(f"no labgrid environment file {target}")
    env = Environment(target)
    places = []
    for role in env.config.get_targets().values():
        resources, _ = target_factory.normalize_config(role)
        places += list(resources.get("RemotePlace", {}))
    if len(places) != 1:
        raise NoPort(
            f"{target} names {len(places)} RemotePlaces ({', '.join(places) or 'none'}): "
            "give one place, as labgrid:PLACE"
        )
    return places[0], env.config.get_option("coordinator_address", None)


class Coordinator:
    """A labgrid client session, its event loop on a thread of its own: one per
    coordinator and process, shared by the boards that use it (gRPC gives channels to
    one address one connection, and the coordinator takes one session per connection)."""

    _open: dict[str, Coordinator] = {}
    _lock = threading.Lock()

    @classmethod
    def attach(cls, address: str) -> Coordinator:
        with cls._lock:
            if address not in cls._open:
                cls._open[address] = Coordinator(address)
            coordinator = cls._open[address]
            coordinator.users += 1
            return coordinator

    def detach(self) -> None:
        with self._lock:
            self.users -= 1
            if self.users == 0:
                del self._open[self.address]
                self.close()

    def __init__(self, address: str):
        self.address = address
        self.users = 0
        self.watchers: list[Callable[[], None]] = []  # called when any place changes
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="labgrid", daemon=True)
        self.thread.start()
        try:
            self.session = self.call(self._connect())
        except BaseException:
            self._stop_loop()
            raise
        changed = self.session.on_place_changed

        async def on_place_changed(place_pb2: Any) -> None:
            await changed(place_pb2)
            for watcher in list(self.watchers):
                watcher()

        self.session.on_place_changed = on_place_changed

    async def _connect(self) -> Any:
        from labgrid.remote.client import ClientSession, Error

        session = ClientSession(self.address, asyncio.get_running_loop())
        root = logging.getLogger()
        root.addFilter(_quiet)
        try:
            await session.start()
        except Error as exc:
            await session.close()
            raise BoardStartError(
                f"cannot reach the labgrid coordinator at {self.address} ({exc}): is "
                "labgrid-coordinator running there? (set LG_COORDINATOR=HOST:PORT)"
            ) from None
        finally:
            root.removeFilter(_quiet)
        return session

    def call(self, coro: Coroutine[Any, Any, Any], timeout_s: float = _CALL_TIMEOUT_S) -> Any:
        """Runs a coroutine on the session's loop and waits for it."""
        future = asyncio.run_coroutine_threadsafe(coro, self.loop)
        try:
            return future.result(timeout_s)
        except concurrent.futures.TimeoutError:
            future.cancel()
            raise BoardStartError(
                f"the labgrid coordinator at {self.address} did not answer within {timeout_s:.0f} s"
            ) from None

    def stub(self, method: str, request: Any) -> Any:
        """One coordinator call; a refusal raises BoardStartError with its reason."""
        import grpc

        async def go() -> Any:
            try:
                reply = await getattr(self.session.stub, method)(request)
            except grpc.aio.AioRpcError as exc:
                raise BoardStartError(f"labgrid coordinator: {exc.details()}") from None
            await self.session.sync_with_coordinator()
            return reply

        return self.call(go())

    def place(self, name: str) -> Any:
        return self.session.places.get(name)

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.call(self.session.stop())
            self.call(self.session.close())
        self._stop_loop()

    def _stop_loop(self) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5.0)
        if not self.thread.is_alive():
            self.loop.close()


class LabgridBoard(SerialBoard):
    """A Mega (or a virtual one) on a labgrid place; flashable through its bootloader."""

    connect_timeout_s = 10.0  # the port comes back after the board's reset (USB re-enumeration)

    def __init__(
        self,
        target: str,
        options: BoardOptions | None = None,
        labgrid: LabgridOptions | None = None,
    ):
        self.place, env_coordinator = place_of(target)
        super().__init__(f"labgrid:{self.place}", options)
        self.labgrid = labgrid or LabgridOptions()
        self.coordinator_address = env_coordinator or self.labgrid.coordinator
        self.coordinator: Coordinator | None = None
        self.acquired_here = False  # we hold it (and so release it)
        self.lost = ""  # what happened to the place while we held it
        self._port: serial.SerialBase | None = None
        self._usage: dict[str, Any] = {}  # this use, for the usage log
        self._held_since: float | None = None

    def check(self) -> None:
        """The coordinator answers and knows the place: refused before anything is built."""
        coordinator = Coordinator.attach(self.coordinator_address)
        try:
            self.coordinator = coordinator
            self._known_place()
        finally:
            self.coordinator = None
            coordinator.detach()

    # -- acquire and release -----------------------------------------------

    def start(self) -> str:
        self.coordinator = Coordinator.attach(self.coordinator_address)
        started = time.monotonic()
        self._usage = {"place": self.place, "coordinator": self.coordinator_address}
        self._usage["user"] = self._me()
        try:
            self._acquire()
        finally:
            self._usage["waited_s"] = round(time.monotonic() - started, 3)
        self._usage["acquired_at"] = datetime.now(UTC).isoformat(timespec="seconds")
        self._held_since = time.monotonic()
        self.coordinator.watchers.append(self._check_place)
        return self._serial_url()

    def _me(self) -> str:
        host = os.environ.get("LG_HOSTNAME", socket.gethostname())
        return f"{host}/{os.environ.get('LG_USERNAME', getpass.getuser())}"

    def _known_place(self) -> Any:
        assert self.coordinator is not None
        place = self.coordinator.place(self.place)
        if place is None:
            known = ", ".join(sorted(self.coordinator.session.places)) or "none"
            raise NoPort(
                f"no labgrid place {self.place!r} at {self.coordinator_address} "
                f"(places: {known}); `labgrid-client -p {self.place} create` makes one"
            )
        return place

    def _acquire(self) -> None:
        """Acquires the place, waiting in a labgrid reservation while someone holds it, for
        `wait_s` at most. Held under our own name is held too: by another vehil of ours
        (`--jobs`), whose board this one must not reset under it."""
        from labgrid.remote.common import ReservationState
        from labgrid.remote.generated import labgrid_coordinator_pb2 as pb2

        assert self.coordinator is not None
        self._known_place()
        reply = self.coordinator.stub(
            "CreateReservation",
            pb2.CreateReservationRequest(
                filters={"main": pb2.Reservation.Filter(filter={"name": self.place})}, prio=0.0
            ),
        )
        token = reply.reservation.token
        deadline = time.monotonic() + self.labgrid.wait_s
        try:
            while True:
                state = self.coordinator.stub(
                    "PollReservation", pb2.PollReservationRequest(token=token)
                ).reservation.state
                if ReservationState(state) is ReservationState.allocated:
                    break
                if time.monotonic() > deadline:
                    holder = self._known_place().acquired or "a reservation ahead of ours"
                    if holder == self._me():
                        holder += " (you: another vehil, or labgrid-client acquire)"
                    raise BoardStartError(
                        f"labgrid place {self.place} is still held by {holder} after "
                        f"{self.labgrid.wait_s:.0f} s of waiting: retry later, wait longer "
                        f"(--acquire-timeout), or ask them to release it (`labgrid-client -p "
                        f"{self.place} release`)"
                    )
                time.sleep(_POLL_S)
            self.coordinator.stub("AcquirePlace", pb2.AcquirePlaceRequest(placename=self.place))
            self.acquired_here = True
        finally:
            with contextlib.suppress(BoardStartError):
                self.coordinator.stub(
                    "CancelReservation", pb2.CancelReservationRequest(token=token)
                )

    def stop(self) -> None:
        if self.coordinator is None:
            return
        from labgrid.remote.generated import labgrid_coordinator_pb2 as pb2

        if self._held_since is None:
            ended = "not acquired"
        else:
            ended = f"lost: {self.lost}" if self.lost else "released"
        try:
            if self.acquired_here and not self.lost:
                self.coordinator.stub("ReleasePlace", pb2.ReleasePlaceRequest(placename=self.place))
        finally:
            with contextlib.suppress(ValueError):
                self.coordinator.watchers.remove(self._check_place)
            self.coordinator.detach()
            self.coordinator = None
            self.acquired_here = False
            self._log_usage(ended)

    def _log_usage(self, ended: str) -> None:
        usage = self._usage | {"ended": ended}
        if self._held_since is not None:
            usage["released_at"] = datetime.now(UTC).isoformat(timespec="seconds")
            usage["held_s"] = round(time.monotonic() - self._held_since, 3)
        self._usage, self._held_since = {}, None
        path = self.labgrid.usage_log or runs_dir() / "labgrid-usage.jsonl"
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open(
            "a"
        ) as f:  # one short line per use: appends from several runs interleave whole
            f.write(json.dumps(usage) + "\n")

    def _check_place(self) -> None:
        """On the coordinator's loop, when a place changed: if ours was released or taken
        while we hold it, say so and close the port, so the run stops with that reason."""
        if self.lost or self.coordinator is None:
            return
        place = self.coordinator.place(self.place)
        if place is not None and place.acquired == self._me():
            return
        holder = f"now held by {place.acquired}" if place and place.acquired else "now free"
        self.lost = f"labgrid place {self.place} was released while in use ({holder})"
        if self._port is not None:
            self._port.close()

    # -- the serial port ---------------------------------------------------

    def _serial_url(self) -> str:
        """The place's NetworkSerialPort as a pyserial URL, once the exporter serves it
        (its ser2net starts on acquire, and again on a new port after the board's USB
        serial came back)."""
        assert self.coordinator is not None
        deadline = time.monotonic() + self.connect_timeout_s
        while True:
            if self.lost:
                raise BoardStartError(self.lost)
            found = self._network_port()
            if found is not None and found.avail and found.args.get("port"):
                args = found.args
                if args.get("protocol", "rfc2217") == "raw":
                    return f"socket://{args['host']}:{args['port']}"
                # as labgrid's SerialDriver: ser2net on a pty or a bridge may not
                # confirm DTR/RTS settings
                return f"rfc2217://{args['host']}:{args['port']}?ign_set_control"
            if time.monotonic() > deadline:
                what = "has no NetworkSerialPort" if found is None else "its port is not available"
                raise BoardStartError(
                    f"labgrid place {self.place} {what} (after {self.connect_timeout_s:.0f} s): "
                    "check the exporter (docs/labgrid.md) and the place's matches "
                    f"(`labgrid-client -p {self.place} show`)"
                )
            time.sleep(_POLL_S)

    def _network_port(self) -> Any:
        assert self.coordinator is not None
        session = self.coordinator.session
        place = self._known_place()
        for exporter, group, cls, name in place.acquired_resources:
            if cls == "NetworkSerialPort":
                return session.resources.get(exporter, {}).get(group, {}).get(name)
        return None

    def port_url(self, url: str) -> str:
        # Looked up at each open: the port moves when the board's USB serial comes back.
        return super().port_url(self._serial_url())

    def open_port(self, url: str) -> serial.SerialBase:
        self._port = super().open_port(url)
        return self._port

    def diagnostics(self) -> str:
        """Why the port broke, if the place went: the exporter stops serving the port
        before the coordinator says the place is free, so that news is waited for a moment."""
        deadline = time.monotonic() + _NEWS_WAIT_S
        while not self.lost and self.coordinator is not None and time.monotonic() < deadline:
            time.sleep(_POLL_S / 4)
        return f"\n{self.lost}" if self.lost else ""

    @contextlib.contextmanager
    def programmer_port(self, url: str) -> Iterator[str]:
        """avrdude speaks no RFC 2217: it gets a loopback port relayed to the place's. The
        relay opens the place's port when avrdude connects: ser2net opens the board's
        serial device for each connection, and that open (DTR) resets a Mega into its
        bootloader. (A DTR pulse over RFC 2217 as well would reset it a second time, just
        as avrdude starts talking.)"""
        from vehil.flash import BOOTLOADER_BAUD

        def open_remote() -> serial.SerialBase:
            return serial.serial_for_url(self.port_url(url), baudrate=BOOTLOADER_BAUD, timeout=0.05)

        relay = _Relay(open_remote)
        try:
            yield f"socket://127.0.0.1:{relay.port}"
        finally:
            relay.close()


class _Relay:
    """A loopback TCP port for one client (avrdude), relayed both ways to a serial port
    opened when the client connects."""

    def __init__(self, open_remote: Any):
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.open_remote = open_remote
        self.remote: serial.SerialBase | None = None
        self.client: socket.socket | None = None
        self.thread = threading.Thread(target=self._serve, name="avrdude-relay", daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        try:
            self.client, _ = self.server.accept()
        except OSError:
            return  # closed before anyone came
        self.client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.remote = self.open_remote()
        to_client = threading.Thread(target=self._to_client, daemon=True)
        to_client.start()
        with contextlib.suppress(OSError, serial.SerialException):
            while data := self.client.recv(4096):
                self.remote.write(data)
        self.remote.close()
        to_client.join(2.0)

    def _to_client(self) -> None:
        assert self.remote is not None and self.client is not None
        with contextlib.suppress(OSError, serial.SerialException, TypeError):
            while self.remote.is_open:
                data = self.remote.read(max(1, self.remote.in_waiting))
                if data:
                    self.client.sendall(data)

    def close(self) -> None:
        self.server.close()
        if self.client is not None:
            with contextlib.suppress(OSError):
                self.client.shutdown(socket.SHUT_RDWR)
            self.client.close()
        self.thread.join(5.0)
