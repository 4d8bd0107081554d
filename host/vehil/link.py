"""The host end of the framed serial link.

A Link sends requests over any pyserial port (a pty, a TCP socket, a real
USB serial port, or the in-process native board), matches every reply to its
request by sequence number, keeps no more bytes in flight than the board's RX
buffer holds, and turns every gap, timeout and refusal into an exception:
nothing is dropped silently.

"In flight" counts every copy of a request sent, resends included, until the board
is known to have taken it out of its RX buffer: a reply to that copy or to one sent
after it (the board reads its input in order). A board that stalls for seconds keeps
the copies it has not read; resending them all on each timeout would queue several
buffers' worth behind them and overrun the buffer when it wakes.
"""

from __future__ import annotations

import contextlib
import time
from collections import deque
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import serial

from vehil.errors import (
    BoardError,
    BoardReset,
    BoardTimeout,
    LinkError,
    NotInImage,
    ProtocolMismatch,
)
from vehil.protocol import frame as framing
from vehil.protocol.schema import SCHEMA

_ERROR_NAMES = {v: k for k, v in SCHEMA.error.items()}
_RESET_CAUSES = {v: k for k, v in SCHEMA.reset_cause.items()}
_RESET_STATE = SCHEMA.reset_what["STATE"]
# Seq 0 is reserved for frames the board sends on its own (boot INFO, link errors),
# 0xFFFF for requests slipped in from outside the session (faults:// reboot_after).
_FIRST_SEQ = 1
_LAST_SEQ = framing.SEQ_MAX - 1
MAX_FRAMES_IN_FLIGHT = 32
# Sending these twice leaves the board as sending them once: CONFIG resets the estimator,
# and a SAMPLE's index makes the board answer a repeat from its RESULT cache.
# A CONFIG_PART sent again rewrites the same bytes, and a CONFIG sent again applies the
# same block (the board keeps its parts until a step).
_RETRYABLE = frozenset(
    {"HELLO", "PING", "GET_STATS", "GET_ESTIMATOR", "CONFIG", "CONFIG_PART", "SAMPLE"}
)
_RETRY_BACKOFF_S = (0.01, 0.2)  # first wait, longest wait
_READ_SLICE_S = 0.02
# Before the board's INFO says how large its RX buffer is.
_RX_BUFFER_UNKNOWN = 64


@dataclass
class _Pending:
    """A request in flight: sent again with a new seq when it or its reply is lost."""

    name: str
    body: bytes
    seq: int = 0  # 0: not (yet) sent under its current seq
    wire_bytes: int = 0
    sent_at: float = 0.0

    def __post_init__(self) -> None:
        self.wire_bytes = len(framing.encode(0, 0, self.body))  # whatever the seq

    def describe(self) -> str:
        notes = []
        if self.name == "SAMPLE":  # its index leads the body
            notes.append(f"sample {int.from_bytes(self.body[:2], 'little')}")
        if not self.seq:
            notes.append(
                "not sent again: the copies sent before, unanswered, may still fill the "
                "board's RX buffer"
            )
        seq = f" seq {self.seq}" if self.seq else ""
        return f"{self.name}{seq}" + (f" ({'; '.join(notes)})" if notes else "")


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
        raise NotInImage(
            f"estimator {name!r} is not built into this firmware (built in: {built}): run it "
            "on a board whose image holds it (simavr-ev and qemu-ev hold the EV filters), or "
            "build one that does (platformio.ini's custom_estimators, a project's vehil.toml)"
        )


def config_requests(
    estimator_id: int, mode: int, params: bytes, max_body: int = SCHEMA.max_body
) -> list[tuple[str, dict[str, Any]]]:
    """The requests that configure an estimator: its parameter block in one CONFIG if it
    fits a frame, else CONFIG_PARTs of whole values and a CONFIG with the rest."""
    config_room = max_body - SCHEMA.messages["CONFIG"].fixed_size
    part_room = max_body - SCHEMA.messages["CONFIG_PART"].fixed_size
    part_room -= part_room % 4  # whole 4-byte values per frame
    requests: list[tuple[str, dict[str, Any]]] = []
    offset = 0
    while len(params) - offset > config_room:
        requests.append(
            ("CONFIG_PART", {"offset": offset, "params": params[offset : offset + part_room]})
        )
        offset += part_room
    fields = {"estimator": estimator_id, "mode": mode, "offset": offset, "params": params[offset:]}
    return [*requests, ("CONFIG", fields)]


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
        "OUT_OF_ORDER": (
            f"the board holds {detail} parameter bytes: send the CONFIG_PARTs before in order"
            if req in ("CONFIG", "CONFIG_PART")
            else f"the board expects SAMPLE index {detail}"
        ),
        "PARAMS_OVERSIZE": f"the board holds at most {detail} parameter bytes",
        "UNKNOWN_TYPE": "the firmware does not know this request",
    }.get(code, f"detail {detail}")
    return f"board refused {req}: {code} ({explain})"


class Link:
    """Framed request/reply over an open pyserial port."""

    def __init__(
        self,
        port: serial.SerialBase,
        *,
        timeout_s: float = 2.0,
        retries: int = 5,
        max_frames: int | None = None,
    ):
        self.port = port
        self.timeout_s = timeout_s
        # Every seq sent, with its request's type: a reply's CRC covers that type, so a
        # reply is accepted only as the answer to the request it was made for. One byte per
        # seq (0: never sent), so a long run's link takes no more memory than a short one's.
        self._sent_types = bytearray(_LAST_SEQ + 1)
        self.decoder = framing.StreamDecoder(
            answers=lambda seq: self._sent_types[seq] if seq <= _LAST_SEQ else 0
        )
        self.info: BoardInfo | None = None
        self._seq = _FIRST_SEQ
        self._inbox: deque[tuple[framing.Frame, float]] = deque()
        self.stale_replies = 0
        self.wrong_type_replies = 0
        self.retries = retries  # for requests that sending twice does not change
        self.max_frames = max_frames or MAX_FRAMES_IN_FLIGHT  # a board may ask for fewer
        self.retried = 0
        self.sample_index = 0  # the next SAMPLE's index: 0 after CONFIG
        # Copies sent that the board may not have read yet: (seq, wire bytes), oldest first.
        self._unread: deque[tuple[int, int]] = deque()
        self._unread_seqs: set[int] = set()
        self.in_flight = 0  # their bytes: never more than the board's RX buffer
        self.probes = 0  # empty PINGs sent to learn that the board has read its input
        self._probe_seq = 0
        self._held: bytearray | None = None  # frames sent while corked, not yet written
        # Short reads, set once: changing a real port's timeout reconfigures the tty.
        self.port.timeout = _READ_SLICE_S
        # A port that hands over all that has arrived in one call (tcp://)
        self._read_waiting = getattr(port, "read_waiting", None)

    # -- bytes and frames ------------------------------------------------

    def _next_seq(self) -> int:
        seq = self._seq
        self._seq = seq + 1 if seq < _LAST_SEQ else _FIRST_SEQ
        return seq

    def _read_frame(self, deadline: float) -> tuple[framing.Frame, float] | None:
        """Next frame with its arrival time, or None once the deadline has passed."""
        self._write_held()
        while not self._inbox:
            if time.perf_counter() > deadline:
                return None
            try:
                if self._read_waiting is not None:
                    data = self._read_waiting()
                else:
                    data = self.port.read(max(1, self.port.in_waiting))
            except (serial.SerialException, OSError) as exc:  # a vanished pty raises EIO
                raise LinkError(f"the connection to the board broke: {exc}") from None
            if data:
                now = time.perf_counter()
                for f in self.decoder.feed(data):
                    self._read_up_to(f)
                    self._inbox.append((f, now))
        return self._inbox.popleft()

    # -- what the board's RX buffer holds -----------------------------------

    @property
    def rx_buffer(self) -> int:
        return self.info.rx_buffer if self.info else _RX_BUFFER_UNKNOWN

    def _fits(self, wire_bytes: int) -> bool:
        return self.in_flight + wire_bytes <= self.rx_buffer

    def _sent_copy(self, seq: int, wire_bytes: int) -> None:
        self._unread.append((seq, wire_bytes))
        self._unread_seqs.add(seq)
        self.in_flight += wire_bytes

    def _read_up_to(self, f: framing.Frame) -> None:
        """A frame from the board: every copy sent up to the one it answers has been read."""
        if f.seq == 0 and f.name == "INFO":  # rebooted: its RX buffer starts empty
            self._unread.clear()
            self._unread_seqs.clear()
            self.in_flight = 0
        if f.seq not in self._unread_seqs:
            return
        while self._unread:
            seq, n = self._unread.popleft()
            self._unread_seqs.discard(seq)
            self.in_flight -= n
            if seq == f.seq:
                return

    def _send(self, name: str, seq: int, body: bytes) -> tuple[bytes, float]:
        type_code = SCHEMA.messages[name].type
        self._sent_types[seq] = type_code
        wire = framing.encode(type_code, seq, body)
        if self._held is not None:
            self._held += wire
        else:
            self._write(wire)
        return wire, time.perf_counter()

    def _write(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f"the connection to the board broke: {exc}") from None

    def _write_held(self) -> None:
        if self._held:
            data, self._held = bytes(self._held), bytearray()
            self._write(data)

    @contextlib.contextmanager
    def corked(self) -> Iterator[None]:
        """Within the block, frames sent are held and written together, in one write,
        when the link next waits for a frame or the block ends: a burst of requests then
        reaches the board back to back at the line rate, however slowly the host packs
        them (a request's sent_at is when it was packed)."""
        self._held = bytearray()
        try:
            yield
        finally:
            try:
                self._write_held()
            finally:
                self._held = None

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
                return self._info_fields(f)
        raise BoardTimeout(
            f"no ready frame from the board within {timeout_s:.1f} s "
            f"(received {self.decoder.bad_frames} undecodable frames; "
            f"last problem: {self.decoder.last_error or 'none'})"
        )

    @staticmethod
    def _info_fields(f: framing.Frame) -> dict[str, Any]:
        """INFO's fields once its protocol version and schema hash (its first five bytes,
        whatever the rest's layout) are this host's."""
        protocol = f.body[0] if f.body else None
        schema_hash = int.from_bytes(f.body[1:5], "little") if len(f.body) >= 5 else None
        fix = "rebuild and reflash the firmware (`vehil build`) or install the matching host"
        if protocol != SCHEMA.protocol_version:
            raise ProtocolMismatch(
                f"firmware speaks protocol v{protocol}, this host speaks "
                f"v{SCHEMA.protocol_version}: {fix}"
            )
        if schema_hash != SCHEMA.hash:
            got = "none" if schema_hash is None else f"{schema_hash:08x}"
            raise ProtocolMismatch(
                f"firmware was built from another messages.toml of protocol v{protocol} "
                f"(schema hash {got}, this host's {SCHEMA.hash:08x}): {fix}"
            )
        return f.fields()

    def pipeline(
        self,
        requests: Iterable[tuple[str, dict[str, Any]]],
        *,
        window: int | None = None,
        retries: int | None = None,
    ) -> Iterator[Reply]:
        """Sends requests keeping the board's RX buffer from overflowing; yields replies in order.

        A request or reply lost on the way (timeout, or a later reply first) is sent
        again with everything sent after it (go-back-N), `retries` times with backoff,
        if all of them are retryable (`retries`: this call's own count instead of the
        link's); then BoardTimeout or LinkError names the request.
        Raises BoardError for an ERROR reply.
        """
        max_frames = min(window or self.max_frames, self.max_frames)
        pending: deque[_Pending] = deque()
        last_reply_at = 0.0
        for name, fields in requests:
            if name == "SAMPLE" and "index" not in fields:
                fields = {"index": self.sample_index, **fields}
                self.sample_index = (self.sample_index + 1) & 0xFFFF
            elif name == "CONFIG" or (name == "RESET" and fields.get("what") == _RESET_STATE):
                self.sample_index = 0  # the board counts from 0 again
            request = _Pending(name, SCHEMA.messages[name].pack(**fields))
            while pending and (
                len(pending) >= max_frames
                or pending[-1].seq == 0
                or not self._fits(request.wire_bytes)
            ):
                reply = self._next_reply(pending, last_reply_at, retries)
                last_reply_at = reply.sent_at + reply.rtt_s
                yield reply
            pending.append(request)
            self._send_what_fits(pending)
        while pending:
            reply = self._next_reply(pending, last_reply_at, retries)
            last_reply_at = reply.sent_at + reply.rtt_s
            yield reply

    def _send_what_fits(self, pending: deque[_Pending]) -> bool:
        """Sends the requests not yet sent, in order, while the board's RX buffer has room
        for them beside every copy it may not have read; False if none went."""
        sent = False
        for request in pending:
            if request.seq:
                continue
            if not self._fits(request.wire_bytes):
                break
            self._transmit(request)
            sent = True
        return sent

    def _probe(self) -> None:
        """An empty PING, when nothing else fits: its reply says the board has read all
        that was sent before it, lost or not, so the resends can go."""
        wire_bytes = len(framing.encode(0, 0, b""))
        if self._fits(wire_bytes) and self._probe_seq not in self._unread_seqs:
            self._probe_seq = self._next_seq()
            self._send("PING", self._probe_seq, b"")
            self._sent_copy(self._probe_seq, wire_bytes)
            self.probes += 1

    def _transmit(self, request: _Pending) -> None:
        request.seq = self._next_seq()
        _, request.sent_at = self._send(request.name, request.seq, request.body)
        self._sent_copy(request.seq, request.wire_bytes)

    def _next_reply(
        self, pending: deque[_Pending], last_reply_at: float, retries: int | None
    ) -> Reply:
        retries = self.retries if retries is None else retries
        started = time.perf_counter()
        for attempt in range(retries + 1):
            try:
                reply = self._await(pending[0], pending, last_reply_at)
                pending.popleft()
                return reply
            except (BoardReset, BoardError):
                raise
            except LinkError as exc:
                if attempt == retries or any(p.name not in _RETRYABLE for p in pending):
                    if not attempt:
                        raise
                    waited = time.perf_counter() - started
                    raise type(exc)(
                        f"{exc}, the last of {attempt + 1} tries over {waited:.1f} s"
                    ) from None
            self.retried += 1
            time.sleep(min(_RETRY_BACKOFF_S[0] * 2**attempt, _RETRY_BACKOFF_S[1]))
            for p in pending:  # go back N: each goes again, under a new seq, as room allows
                p.seq = 0
            if not self._send_what_fits(pending):
                self._probe()
            last_reply_at = 0.0
        raise AssertionError("unreachable")

    def _await(self, request: _Pending, pending: deque[_Pending], last_reply_at: float) -> Reply:
        answer = SCHEMA.messages[request.name].reply
        waiting_since = time.perf_counter()
        while True:
            self._send_what_fits(pending)
            # Replies come in order: this one's clock starts when it was sent and the
            # previous one arrived; one not yet sent waits for room, as long.
            if request.seq:
                deadline = max(request.sent_at, last_reply_at) + self.timeout_s
            else:
                deadline = waiting_since + self.timeout_s
            if (got := self._read_frame(deadline)) is None:
                break
            f, arrived = got
            if request.seq and f.seq == request.seq and f.name not in (answer, "ERROR"):
                # Not an answer to this request: a frame with a borrowed seq (masquerade).
                self.wrong_type_replies += 1
                continue
            if request.seq and f.seq == request.seq:
                if f.name == "ERROR":
                    fields = f.fields()
                    raise BoardError(
                        describe_error(fields),
                        _ERROR_NAMES.get(fields["code"], str(fields["code"])),
                        request.name,
                        fields["detail"],
                    )
                rtt = arrived - request.sent_at
                return Reply(f, request.name, request.sent_at, rtt, request.wire_bytes, f.wire_size)
            if f.seq == 0:
                raise self._unsolicited(f)
            if any(p.seq == f.seq for p in pending if p is not request):
                raise LinkError(
                    f"reply to {request.describe()} is missing: the reply to seq {f.seq} came first"
                )
            self.stale_replies += 1  # a reply to a request sent again since, or to a probe
        raise BoardTimeout(
            f"no reply to {request.describe()} within {self.timeout_s:.2f} s "
            f"({len(pending) - 1} more requests in flight, "
            f"{self.decoder.bad_frames} bad frames seen"
            f"{': ' + self.decoder.last_error if self.decoder.last_error else ''}; "
            "a board slower to answer needs a longer --timeout)"
        )

    def request(self, name: str, *, retries: int | None = None, **fields: Any) -> Reply:
        """One request, stop-and-wait; sent again after a loss if it is retryable (a SAMPLE
        is: the board answers a repeat from its RESULT cache without stepping again)."""
        return next(self.pipeline([(name, fields)], window=1, retries=retries))

    # -- the protocol's verbs --------------------------------------------

    def hello(self) -> BoardInfo:
        fields = self._info_fields(self.request("HELLO", protocol=SCHEMA.protocol_version).frame)
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
        # More samples in flight than the board keeps RESULTs for could not be resent.
        self.max_frames = min(self.max_frames, fields["result_cache"])
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
        self.config(est.id, SCHEMA.mode[mode], params)

    def config(self, estimator_id: int, mode: int, params: bytes) -> Reply:
        """CONFIG by wire id and mode code, in parts when the block needs them (stop-and-
        wait: a part lost is sent again before the next); the CONFIG's reply."""
        for name, fields in config_requests(estimator_id, mode, params):
            reply = self.request(name, **fields)
        return reply

    def set_baud(self, baud: int) -> None:
        """Switches board and host to a new baud rate (the board ACKs at the old one)."""
        self.request("SET_BAUD", baud=baud)
        self.port.baudrate = baud
        if self.info is not None:
            self.info.fields["baud"] = baud

    def close(self) -> None:
        self.port.close()
