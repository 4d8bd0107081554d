"""What the link does under each fault: `python -m vehil.faults_report [--board B]`.

`--campaign` instead counts, per board, fault class and rate, how many faults were
injected into how many exchanges, and what became of each exchange a fault hit:
refused (detected), answered right anyway (harmless), or accepted with a wrong answer
(wrongly accepted: must stay 0). It runs until `--faults-per-class` faults are in or
`--seconds` have gone by, per row, and says which ended it.

Per fault class and rate (per byte, both directions, seeded): PINGs sent once
(detected = refused or timed out, wrongly accepted = an echo that differs), then
with retries (recovered); SAMPLEs streamed through passthrough, every lost request
or reply sent again with what followed it (go-back-N; the board answers a repeated
sample from its RESULT cache), until the stream ends or a sample is lost for good
(which must be reported, never skipped); and the time from a board reset to its
next ready frame.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import random
import struct
import sys
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from typing import Any

from rich.console import Console
from rich.table import Table

from vehil.boards import BoardOptions, open_board
from vehil.errors import BoardError, LinkError, VehilError
from vehil.protocol import frame as framing
from vehil.protocol.schema import SCHEMA
from vehil.terminal import make_console
from vehil.transports.protocol_faults import ByteFaults

CLASSES = ("drop", "flip", "dup", "insert")
RATES = (1e-3, 1e-2)


def measure(
    board: str, kind: str, rate: float, pings: int = 100, samples: int = 2000, retries: int = 3
) -> dict[str, Any]:
    """One fault class at one rate (see the module's doc); `retries`: how many times each
    PING of the second round may be sent again."""
    rng = random.Random(1)
    timeout_s = 0.1 if board == "simavr" else 0.3
    with open_board(
        board, BoardOptions(timeout_s=timeout_s, faults=f"{kind}={rate},seed=9")
    ) as link:
        ok = detected = wrong = 0
        for _ in range(pings):
            payload = rng.randbytes(16)
            try:
                echo = link.request("PING", retries=0, payload=payload).fields()["payload"]
            except LinkError:
                detected += 1
                continue
            ok += 1
            wrong += echo != payload
        recovered = 0
        for _ in range(pings):
            with contextlib.suppress(LinkError):  # all retries lost: counted as not recovered
                echo = link.request("PING", retries=retries, payload=b"again").fields()["payload"]
                recovered += echo == b"again"
        link.configure("passthrough", "F32")
        streamed, loss, resent = 0, "", link.retried
        try:
            inputs = (struct.pack("<4f", k, k, k, k) for k in range(samples))
            # at 1e-2 per byte half the exchanges fail
            samples_out = link.pipeline((("SAMPLE", {"inputs": x}) for x in inputs), retries=20)
            for k, reply in enumerate(samples_out):
                if reply.fields()["outputs"] != struct.pack("<4f", k, k, k, k):
                    wrong += 1
                streamed += 1
        except LinkError as exc:
            loss = str(exc)
        resent = link.retried - resent
        injected = sum(link.port.counts.values())
        # The board's count is read with the faults off: at 1e-2 a byte a GET_STATS reply
        # is lost more often than not, and its retries are not what is being measured.
        link.port.disarm()
        replayed = link.stats()["replayed"] if not loss else -1
    return {
        "class": kind,
        "rate": rate,
        "injected": injected,
        "sent": pings,
        "ok": ok,
        "detected": detected,
        "wrong": wrong,
        "recovered": recovered,
        "samples": samples,
        "streamed": streamed,
        "resent": resent,
        "replayed": replayed,
        "loss": loss,
    }


# Stop-and-wait PINGs with no retry: how long a lost request or reply is waited for.
# Shorter than a board's worst round trip only turns late replies into detected losses.
CAMPAIGN_TIMEOUT_S = {"native": 0.005, "simavr": 0.03, "qemu": 0.3}


@dataclass
class CampaignRow:
    """One board, fault class and rate: exchanges and what the faults did to them."""

    board: str
    kind: str
    rate: float
    frames: int = 0  # PING requests sent, each answered by one reply frame
    injected: int = 0  # faults put on the wire, both directions
    hit: int = 0  # exchanges with at least one fault in their bytes
    detected: int = 0  # exchanges hit and refused: timeout, bad frame, wrong seq or type, ERROR
    lost_unhit: int = 0  # refused with no fault in its bytes: a late reply, or the one before's
    harmless: int = 0  # hit, yet the echo came back right (a doubled delimiter, say)
    wrong: int = 0  # accepted with an echo that differs from what was sent
    seconds: float = 0.0
    ended_by: str = ""

    def until(self, faults: int, max_s: float) -> Iterator[None]:
        """Once per exchange, until `faults` are in or `max_s` have gone by."""
        start = time.perf_counter()
        while self.injected < faults and self.seconds < max_s:
            yield
            self.seconds = time.perf_counter() - start
        self.ended_by = "faults" if self.injected >= faults else "time"

    def count(self, injected: int, right: bool, wrong: int) -> None:
        """One exchange: the faults in its bytes, whether its right answer was accepted,
        and how many wrong ones were."""
        self.frames += 1
        self.injected += injected
        self.hit += injected > 0
        self.wrong += wrong
        if not right and not wrong:
            if injected:
                self.detected += 1
            else:
                self.lost_unhit += 1
        elif right and injected:
            self.harmless += 1


CODEC = "codec"  # the host's frame decoder alone, fed broken reply frames: no board, no timeouts


def codec_row(kind: str, rate: float, faults: int, max_s: float, seed: int = 1) -> CampaignRow:
    """PING replies as a board frames them, broken on the way and fed to the host's frame
    decoder: a frame it passes that differs from the one sent got through COBS and the
    CRC corrupted. Fast enough to reach the counts where a check's residual rate shows."""
    row = CampaignRow(CODEC, kind, rate)
    rng = random.Random(seed)
    faulty = ByteFaults({kind: rate}, seed)
    ping, pong = SCHEMA.messages["PING"], SCHEMA.messages["PONG"]
    # As the link does: only the seq in flight answers a request (a PING), whose type the
    # reply's CRC must cover.
    decoder = framing.StreamDecoder(answers=lambda seq: ping.type if seq == sent.seq else 0)
    for _ in row.until(faults, max_s):
        body = pong.pack(timestamp=rng.getrandbits(32), payload=rng.randbytes(rng.randint(1, 32)))
        sent = framing.Frame(pong.type, row.frames & framing.SEQ_MAX, body)
        wire = framing.encode(sent.type, sent.seq, body, answers=ping.type)
        before = faulty.counts.total()
        got = decoder.feed(faulty.apply(wire, "from board"))
        row.count(faulty.counts.total() - before, sent in got, sum(f != sent for f in got))
    return row


def campaign_row(
    board: str, kind: str, rate: float, faults: int, max_s: float, seed: int = 1
) -> CampaignRow:
    """PINGs of random length and content, each checked against its echo."""
    if board == CODEC:
        return codec_row(kind, rate, faults, max_s, seed)
    row = CampaignRow(board, kind, rate)
    rng = random.Random(seed)
    timeout_s = CAMPAIGN_TIMEOUT_S.get(board, 0.1)
    with open_board(
        board, BoardOptions(timeout_s=timeout_s, faults=f"{kind}={rate},seed={seed}")
    ) as link:
        counts = link.port.counts
        for _ in row.until(faults, max_s):
            payload = rng.randbytes(rng.randint(1, 32))
            before = counts.total()
            try:
                echo = link.request("PING", retries=0, payload=payload).fields()["payload"]
            except (LinkError, BoardError, ValueError):  # ValueError: a body of the wrong shape
                echo = None
            row.count(counts.total() - before, echo == payload, echo not in (None, payload))
    return row


def campaign_table(rows: list[CampaignRow], faults: int, max_s: float) -> Table:
    t = Table(
        title=f"link fault campaign: stop-and-wait PINGs of 1-32 random bytes, no retries; "
        f"each row until {faults:,g} faults or {max_s:g} s"
    )
    for col in ("board", "class", "rate", "frames", "injected", "exchanges hit", "detected",
                "harmless", "wrongly accepted", "lost, not hit", "s", "ended by"):  # fmt: skip
        t.add_column(col, justify="left" if col in ("board", "class", "ended by") else "right")
    for r in rows:
        t.add_row(
            r.board,
            r.kind,
            f"{r.rate:g}",
            f"{r.frames:,}",
            f"{r.injected:,}",
            f"{r.hit:,}",
            f"{r.detected:,}",
            f"{r.harmless:,}",
            f"[bold red]{r.wrong:,}[/]" if r.wrong else "0",
            f"{r.lost_unhit:,}",
            f"{r.seconds:.0f}",
            r.ended_by,
        )
    return t


def run_campaign(args: argparse.Namespace, console: Console) -> int:
    rows = []
    for board in args.board.split(","):
        for kind in args.classes.split(","):
            for rate in (float(r) for r in args.rates.split(",")):
                try:
                    r = campaign_row(board, kind, rate, int(args.faults_per_class), args.seconds)
                except VehilError as exc:  # a board that did not start: the other rows go on
                    r = CampaignRow(board, kind, rate, ended_by=f"error: {exc}")
                rows.append(r)
                console.print(
                    f"{board} {kind} {rate:g}: {r.injected:,} faults in {r.frames:,} frames, "
                    f"{r.detected:,} detected, {r.wrong} wrongly accepted ({r.seconds:.0f} s)",
                    style="dim",
                )
    if args.json:
        sys.stdout.write(json.dumps([asdict(r) for r in rows], indent=2) + "\n")
    else:
        console.print(campaign_table(rows, args.faults_per_class, args.seconds))
    if any(r.ended_by.startswith("error") for r in rows):
        return 2
    return 1 if any(r.wrong for r in rows) else 0


def reset_recovery_s(board: str, what: str = "REBOOT") -> float:
    """From a reboot request or a hang (HANG: the watchdog must act) to HELLO answered."""
    with open_board(board) as link:
        start = time.perf_counter()
        link.request("RESET", what=SCHEMA.reset_what[what])
        link.wait_ready(10.0)
        link.hello()
        return time.perf_counter() - start


def resumed_run(board: str, scenario_name: str = "mixed", duration: float = 20.0) -> str:
    """A lockstep run with a reboot slipped in half-way: how it caught up."""
    import dataclasses

    from vehil import runner, scenario
    from vehil.boards import make_board

    sc = dataclasses.replace(scenario.load(scenario_name), duration=duration)
    n = int(duration / sc.sample_time)
    run = runner.run(
        sc,
        make_board(board, BoardOptions(faults=f"reboot_after={n // 2}")),
        console=Console(quiet=True),
    )
    if run.error or not run.resumes:
        return f"not resumed: {run.error or 'no reset seen'}"
    r = run.resumes[0]
    return (
        f"{run.done:,}/{n:,} samples of {scenario_name}; reset before sample {r.at_sample:,}, "
        f"caught up in {r.recovery_s * 1e3:.0f} ms"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m vehil.faults_report", description=__doc__)
    parser.add_argument("--board", default="simavr")
    parser.add_argument("--samples", type=int, default=2000, help="SAMPLEs streamed per point")
    parser.add_argument(
        "--campaign", action="store_true", help="count faults and their fate (see above)"
    )
    parser.add_argument("--faults-per-class", type=float, default=1e5, help="campaign: per row")
    parser.add_argument("--seconds", type=float, default=600.0, help="campaign: at most, per row")
    parser.add_argument("--classes", default=",".join(CLASSES), help="campaign: fault classes")
    parser.add_argument(
        "--rates", default=",".join(map(str, RATES)), help="campaign: per-byte fault rates"
    )
    parser.add_argument("--json", action="store_true", help="the figures as JSON on stdout")
    args = parser.parse_args(argv)
    console = make_console(stderr=args.json)
    if args.campaign:
        return run_campaign(args, console)
    t = Table(title=f"{args.board}: link faults (per byte, both directions)")
    for col in (
        "class",
        "rate",
        "injected",
        "PINGs right",
        "detected",
        "wrongly accepted",
        "recovered with retries",
        "SAMPLEs through",
        "go-back-N resends",
        "answered from cache",
        "loss reported as",
    ):
        t.add_column(col, justify="right" if col not in ("class", "loss reported as") else "left")
    rows = []
    for kind in CLASSES:
        for rate in RATES:
            r = measure(args.board, kind, rate, samples=args.samples)
            rows.append(r)
            t.add_row(
                kind,
                f"{rate:g}",
                str(r["injected"]),
                f"{r['ok']}/{r['sent']}",
                str(r["detected"]),
                str(r["wrong"]),
                f"{r['recovered']}/{r['sent']}",
                f"{r['streamed']}/{r['samples']}",
                str(r["resent"]),
                str(r["replayed"]) if r["replayed"] >= 0 else "-",
                r["loss"] or "-",
            )
    if not args.json:
        console.print(t)
    figures: dict[str, Any] = {"board": args.board, "faults": rows}
    figures["reset_to_ready_s"] = reset_recovery_s(args.board)
    console.print(f"board reset to ready again: {figures['reset_to_ready_s'] * 1e3:.0f} ms")
    if args.board == "simavr":  # QEMU's mega2560 has no watchdog
        hang = figures["watchdog_to_ready_s"] = reset_recovery_s(args.board, what="HANG")
        console.print(f"board hung, watchdog reset, ready again: {hang * 1e3:.0f} ms")
    figures["reset_mid_run"] = resumed_run(args.board)
    console.print(f"a run with a board reset half-way: {figures['reset_mid_run']}")
    if args.json:
        sys.stdout.write(json.dumps(figures, indent=2) + "\n")
    return 1 if any(r["wrong"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
