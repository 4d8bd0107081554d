"""`faults://INNER?drop=P&flip=P&dup=P&insert=P&delay_ms=D&reboot_after=N&seed=N`: a port
that breaks bytes.

Wraps any other pyserial URL (a board's pty, `socket://...`, `native://`) and injects,
at seeded rates per byte and in both directions: loss (`drop`), a flipped bit
(`flip`), repetition (`dup`) and insertion of a random byte (`insert`); `delay_ms`
holds each write back; `reboot_after` slips a reboot request in after that many
writes, once (a board reset mid-run). It is AUTOSAR E2E's fault model at the byte level: what the
link must detect and never turn into a wrong accepted result. `counts` says what
was injected. Faults start when `arm()` is called (boards arm it once the session
is up), so a run can be broken on purpose without breaking its start; `disarm()` ends
them, so what the board counted can be read after.

`wrap_url(url, spec)` builds the URL; spec is `drop=1e-3,flip=1e-3,seed=7`.
"""

from __future__ import annotations

import random
import time
import urllib.parse
from collections import Counter

from serial.serialutil import SerialException

from vehil.protocol import frame
from vehil.protocol.schema import SCHEMA
from vehil.transports.wrapping import WrappingSerial

KINDS = ("drop", "flip", "dup", "insert")
_OPTIONS = ("delay_ms", "reboot_after", "seed")
# RESET REBOOT with a seq the host never uses for its own requests in flight.
_RESET = SCHEMA.messages["RESET"]
_REBOOT = frame.encode(_RESET.type, frame.SEQ_MAX, _RESET.pack(what=SCHEMA.reset_what["REBOOT"]))


def parse_spec(spec: str) -> dict[str, float]:
    """`drop=1e-3,flip=1e-3,seed=7` -> rates; raises ValueError naming a bad item."""
    out: dict[str, float] = {}
    for item in filter(None, (s.strip() for s in spec.replace("&", ",").split(","))):
        key, _, value = item.partition("=")
        if key not in (*KINDS, *_OPTIONS):
            raise ValueError(
                f"unknown fault {key!r}: use {', '.join((*KINDS, *_OPTIONS))} (e.g. drop=1e-3)"
            )
        try:
            out[key] = float(value)
        except ValueError:
            raise ValueError(f"fault {key} needs a number, got {value!r}") from None
        if key in KINDS and not 0.0 <= out[key] <= 1.0:
            raise ValueError(f"fault rate {key}={value} is not a probability in [0, 1]")
    return out


def wrap_url(url: str, spec: str) -> str:
    query = urllib.parse.urlencode(parse_spec(spec))
    return f"faults://{url}?{query}"


class ByteFaults:
    """Seeded faults per byte at the given rates; `counts` says what was injected."""

    def __init__(self, rates: dict[str, float], seed: int = 0):
        self.rates = rates
        self.counts: Counter[str] = Counter()
        self._rng = random.Random(seed)

    def apply(self, data: bytes, direction: str) -> bytes:
        out = bytearray()
        rng, rates = self._rng, self.rates
        for byte in data:
            if rng.random() < rates.get("insert", 0.0):
                out.append(rng.randrange(256))
                self.counts[f"insert {direction}"] += 1
            if rng.random() < rates.get("drop", 0.0):
                self.counts[f"drop {direction}"] += 1
                continue
            if rng.random() < rates.get("flip", 0.0):
                byte ^= 1 << rng.randrange(8)
                self.counts[f"flip {direction}"] += 1
            out.append(byte)
            if rng.random() < rates.get("dup", 0.0):
                out.append(byte)
                self.counts[f"dup {direction}"] += 1
        return bytes(out)


class Serial(WrappingSerial):
    """A serial port that passes bytes through another one, breaking some of them."""

    scheme = "faults"

    def open(self) -> None:
        inner, _, query = self._inner_url().rpartition("?")
        if not inner:
            inner, query = query, ""
        try:
            self.rates = parse_spec(query)
        except ValueError as exc:
            raise SerialException(f"{self.portstr}: {exc}") from None
        self.faults = ByteFaults(self.rates, int(self.rates.get("seed", 0)))
        self.counts = self.faults.counts
        self.armed = False
        self._writes = 0
        self._open_inner(inner, self._timeout)
        self.is_open = True

    def arm(self) -> None:
        self.armed = True

    def disarm(self) -> None:
        """Bytes pass unbroken from here on (a measurement read after the faulty run)."""
        self.armed = False

    def _reconfigure_port(self) -> None:
        super()._reconfigure_port()
        if self._inner is not None:
            self._inner.timeout = self._timeout

    def _break(self, data: bytes, direction: str) -> bytes:
        return self.faults.apply(data, direction) if self.armed else data

    @property
    def in_waiting(self) -> int:
        return int(self._require_open().in_waiting)

    def read(self, size: int = 1) -> bytes:
        return self._break(self._require_open().read(size), "from board")

    def write(self, data: bytes) -> int:
        inner = self._require_open()
        if self.armed and self.rates.get("delay_ms"):
            time.sleep(self.rates["delay_ms"] / 1e3)
        inner.write(self._break(bytes(data), "to board"))
        if self.armed and "reboot_after" in self.rates:
            self._writes += 1
            if self._writes == int(self.rates["reboot_after"]):
                inner.write(_REBOOT)
                self.counts["reboot"] += 1
        return len(data)
