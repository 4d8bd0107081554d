"""The host end of the framed serial link.

A Link sends requests over any pyserial port (a pty, a TCP socket, a real
USB serial port, or the in-process native board), matches every reply to its
request by sequence number, keeps no more bytes in flight than the board's RX
buffer holds, and turns every gap, timeout and refusal into an exception:
nothing is dropped silently.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import serial

from vehil.errors import BoardError, BoardReset, BoardTimeout, LinkError, ProtocolMismatch
from vehil.protocol import frame as framing
from vehil.protocol.schema import SCHEMA

_ERROR_NAMES = {v: k for k, v in SCHEMA.error.items()}
_RESET_CAUSES = {v: k for k, v in SCHEMA.reset_cause.items()}
# Seq 0 is reserved for frames the board sends on its own (boot INFO, link errors).
_FIRST_SEQ = 1
MAX_FRAMES_IN_FLIGHT = 32
# Sending these twice leaves the board as sending them once (CONFIG resets the estimator).
_IDEMPOTENT = frozenset({"HELLO", "PING", "GET_STATS", "GET_ESTIMATOR", "CONFIG"})
_RETRY_BACKOFF_S = 0.01
_READ_SLICE_S = 0.02


@dataclass(frozen=True)
class Reply:
    """A reply frame, the request it answers, and the host's round-trip time."""

    frame: framing.Frame
    request: str
    sent_at: float
    rtt_s: float
    request_wire_bytes: int
    reply_wire_bytes: int

    def fields(self) -> dict[str, Any]:
        return self.frame.fields()


@dataclass(frozen=True)
class EstimatorInfo:
    index: int
    id: int
    name: str
    modes: tuple[str, ...]
    n_inputs: int
    n_outputs: int
    n_params: int


@dataclass(frozen=True)
class BoardInfo:
    """INFO plus the estimator registry, as the board reports them."""

    fields: dict[str, Any]
    estimators: tuple[EstimatorInfo, ...]

    @property
    def f_cpu(self) -> int:
        return int(self.fields["f_cpu"])

    @property
    def rx_buffer(self) -> int:
        return int(self.fields["rx_buffer"])

    @property
    def reset_cause(self) -> str:
        return _RESET_CAUSES.get(self.fields["reset_cause"], f"code {self.fields['reset_cause']}")

    @property
    def firmware_version(self) -> str:
        f = self.fields
        dirty = "+dirty" if f["build_dirty"] else ""
        return f"{f['fw_major']}.{f['fw_minor']}.{f['fw_patch']} ({f['build_id']:08x}{dirty})"

    def estimator(self, name: str) -> EstimatorInfo:
        for e in self.estimators:
            if e.name == name:
                return e
        built = ", ".join(e.name for e in self.estimators) or "none"
        raise LinkError(f"estimator {name!r} is not built into this firmware (built in: {built})")


def describe_error(fields: dict[str, Any]) -> str:
    code = _ERROR_NAMES.get(fields["code"], f"code {fields['code']}")
    request = SCHEMA.by_type(fields["request"])
    req = request.name if request else f"type 0x{fields['request']:02X}"
    detail = fields["detail"]
    explain = {
        "BAD_LENGTH": f"body length wrong, expected {detail} bytes",
        "VERSION": f"board speaks protocol v{detail}",
        "UNKNOWN_ESTIMATOR": f"no estimator with id {detail} in this firmware",
        "UNSUPPORTED_MODE": f"numeric mode {detail} not built for this estimator",
        "BAD_PARAM": f"parameter {detail} out of range",
        "NOT_CONFIGURED": "no estimator configured: send CONFIG first",
        "BAD_BAUD": (
            "baud rate unreachable from 16 MHz"
            if detail == 0xFFFF
            else f"baud rate error {detail / 100:.2f} % is beyond the UART's tolerance"
        ),
        "OVERSIZE": f"a frame exceeded the board's {detail}-byte receive buffer",
        "OVERRUN": f"the board's RX buffer overflowed, {detail} bytes lost",
        "UNKNOWN_TYPE": "the firmware does not know this request",
    }.get(code, f"detail {detail}")
    return f"board refused {req}: {code} ({explain})"


class Link:
    """Framed request/reply over an open pyserial port."""

    def __init__(self, port: serial.SerialBase, *, timeout_s: float = 2.0):
        self.port = port
        self.timeout_s = timeout_s
        self.decoder = framing.StreamDecoder()
        self.info: BoardInfo | None = None
        self._seq = _FIRST_SEQ
        self._inbox: deque[tuple[framing.Frame, float]] = deque()
        self.stale_replies = 0
        self.retries = 2  # for requests that change nothing on the board
        self.max_frames = MAX_FRAMES_IN_FLIGHT  # a board may ask for fewer (QEMU)
        self.retried = 0
        # Short reads, set once: changing a real port's timeout reconfigures the tty.
        self.port.timeout = _READ_SLICE_S

    # -- bytes and frames ------------------------------------------------

    def _next_seq(self) -> int:
        seq = self._seq
        self._seq = seq + 1 if seq < 0xFF else _FIRST_SEQ
        return seq

    def _read_frame(self, deadline: float) -> tuple[framing.Frame, float] | None:
        """Next frame with its arrival time, or None once the deadline has passed."""
        while not self._inbox:
            if time.perf_counter() > deadline:
                return None
            try:
                data = self.port.read(max(1, self.port.in_waiting))
            except (serial.SerialException, OSError) as exc:  # a vanished pty raises EIO
                raise LinkError(f"the connection to the board broke: {exc}") from None
            if data:
                now = time.perf_counter()
                self._inbox.extend((f, now) for f in self.decoder.feed(data))
        return self._inbox.popleft()

    def _send(self, name: str, seq: int, body: bytes) -> tuple[bytes, float]:
        wire = framing.encode(SCHEMA.messages[name].type, seq, body)
        try:
            self.port.write(wire)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f"the connection to the board broke: {exc}") from None
        return wire, time.perf_counter()

    def _unsolicited(self, f: framing.Frame) -> LinkError:
        if f.name == "INFO":
            cause = _RESET_CAUSES.get(f.fields().get("reset_cause", 0), "?")
            return BoardReset(
                f"the board rebooted mid-session (reset cause {cause}); its estimator state is gone"
            )
        if f.name == "ERROR":
            return LinkError(describe_error(f.fields()))
        return LinkError(f"unexpected {f.name} frame with seq {f.seq}")

    # -- requests --------------------------------------------------------

    def wait_ready(self, timeout_s: float) -> dict[str, Any]:
        """Waits for the unsolicited INFO a board sends when it has booted."""
        deadline = time.perf_counter() + timeout_s
        while (got := self._read_frame(deadline)) is not None:
            f = got[0]
            if f.name == "INFO" and f.seq == 0:
                fields = f.fields()
                self._check_version(fields)
                return fields
        raise BoardTimeout(
            f"no ready frame from the board within {timeout_s:.1f} s "
            f"(received {self.decoder.bad_frames} undecodable frames; "
            f"last problem: {self.decoder.last_error or 'none'})"
        )

    @staticmethod
    def _check_version(info: dict[str, Any]) -> None:
        if info["protocol"] != SCHEMA.protocol_version:
            raise ProtocolMismatch(
                f"firmware speaks protocol v{info['protocol']}, this host speaks "
                f"v{SCHEMA.protocol_version}: rebuild and reflash the firmware "
                "(`vehil build`) or install the matching host"
            )

    def pipeline(
        self, requests: Iterable[tuple[str, dict[str, Any]]], *, window: int | None = None
    ) -> Iterator[Reply]:
        """Sends requests keeping the board's RX buffer from overflowing; yields replies in order.

        Raises BoardError for an ERROR reply, BoardTimeout if a reply does not come,
        LinkError if a reply is skipped or a frame arrives that answers nothing.
        """
        budget = self.info.rx_buffer if self.info else 64
        max_frames = min(window or self.max_frames, self.max_frames)
        pending: deque[tuple[int, str, bytes, float]] = deque()
        in_flight = 0
        last_reply_at = 0.0
        for name, fields in requests:
            body = SCHEMA.messages[name].pack(**fields)
            size = len(framing.encode(0, 0, body))
            while pending and (len(pending) >= max_frames or in_flight + size > budget):
                reply = self._await(pending.popleft(), pending, last_reply_at)
                in_flight -= reply.request_wire_bytes
                last_reply_at = reply.sent_at + reply.rtt_s
                yield reply
            seq = self._next_seq()
            wire, sent_at = self._send(name, seq, body)
            pending.append((seq, name, wire, sent_at))
            in_flight += len(wire)
        while pending:
            reply = self._await(pending.popleft(), pending, last_reply_at)
            last_reply_at = reply.sent_at + reply.rtt_s
            yield reply

    def _await(
        self,
        request: tuple[int, str, bytes, float],
        later: deque[tuple[int, str, bytes, float]],
        last_reply_at: float,
    ) -> Reply:
        seq, name, wire, sent_at = request
        # Replies come in order: this one's clock starts when the previous one arrived.
        deadline = max(sent_at, last_reply_at) + self.timeout_s
        later_seqs = {p[0] for p in later}
        while (got := self._read_frame(deadline)) is not None:
            f, arrived = got
            if f.seq == seq:
                if f.name == "ERROR":
                    fields = f.fields()
                    raise BoardError(
                        describe_error(fields),
                        _ERROR_NAMES.get(fields["code"], str(fields["code"])),
                        name,
                        fields["detail"],
                    )
                return Reply(f, name, sent_at, arrived - sent_at, len(wire), f.wire_size)
            if f.seq == 0:
                raise self._unsolicited(f)
            if f.seq in later_seqs:
                raise LinkError(
                    f"reply to {name} seq {seq} is missing: the reply to seq {f.seq} came first"
                )
            self.stale_replies += 1  # a reply to a request given up on earlier
        raise BoardTimeout(
            f"no reply to {name} seq {seq} within {self.timeout_s:.2f} s "
            f"({len(later)} more requests in flight, {self.decoder.bad_frames} bad frames seen"
            f"{': ' + self.decoder.last_error if self.decoder.last_error else ''})"
        )

    def request(self, name: str, **fields: Any) -> Reply:
        """One request, stop-and-wait. Requests that change nothing on the board are sent
        again after a lost or broken reply (`retries` times, backing off); the others,
        a SAMPLE above all, are never repeated behind the caller's back."""
        attempts = 1 + (self.retries if name in _IDEMPOTENT else 0)
        for attempt in range(attempts):
            try:
                return next(self.pipeline([(name, fields)], window=1))
            except BoardReset:
                raise
            except LinkError:
                if attempt == attempts - 1:
                    raise
                self.retried += 1
                time.sleep(_RETRY_BACKOFF_S * 2**attempt)
        raise AssertionError("unreachable")

    # -- the protocol's verbs --------------------------------------------

    def hello(self) -> BoardInfo:
        fields = self.request("HELLO", protocol=SCHEMA.protocol_version).fields()
        self._check_version(fields)
        estimators = []
        for i in range(fields["estimators"]):
            e = self.request("GET_ESTIMATOR", index=i).fields()
            modes = tuple(m for m, bit in SCHEMA.mode.items() if e["modes"] & (1 << bit))
            estimators.append(
                EstimatorInfo(
                    i,
                    e["id"],
                    e["name"].decode("ascii", "replace"),
                    modes,
                    e["n_inputs"],
                    e["n_outputs"],
                    e["n_params"],
                )
            )
        self.info = BoardInfo(fields, tuple(estimators))
        return self.info

    def stats(self) -> dict[str, Any]:
        return self.request("GET_STATS").fields()

    def configure(self, estimator: str, mode: str = "F32", params: bytes = b"") -> None:
        if self.info is None:
            self.hello()
        assert self.info is not None
        est = self.info.estimator(estimator)
        if mode not in SCHEMA.mode:
            raise ValueError(f"unknown numeric mode {mode!r}; known: {', '.join(SCHEMA.mode)}")
        self.request("CONFIG", estimator=est.id, mode=SCHEMA.mode[mode], params=params)

    def set_baud(self, baud: int) -> None:
        """Switches board and host to a new baud rate (the board ACKs at the old one)."""
        self.request("SET_BAUD", baud=baud)
        self.port.baudrate = baud
        if self.info is not None:
            self.info.fields["baud"] = baud

    def close(self) -> None:
        self.port.close()
