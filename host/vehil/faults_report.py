"""What the link does under each fault: `python -m vehil.faults_report [--board B]`.

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
import random
import struct
import sys
import time
from typing import Any

from rich.console import Console
from rich.table import Table

from vehil.boards import open_board
from vehil.errors import LinkError
from vehil.terminal import make_console

CLASSES = ("drop", "flip", "dup", "insert")
RATES = (1e-3, 1e-2)


def measure(
    board: str, kind: str, rate: float, pings: int = 100, samples: int = 2000
) -> dict[str, Any]:
    rng = random.Random(1)
    with open_board(board, timeout_s=2.0, faults=f"{kind}={rate},seed=9") as link:
        link.timeout_s = 0.1 if board == "simavr" else 0.3
        link.retries = 0
        ok = detected = wrong = 0
        for _ in range(pings):
            payload = rng.randbytes(16)
            try:
                echo = link.request("PING", payload=payload).fields()["payload"]
            except LinkError:
                detected += 1
                continue
            ok += 1
            wrong += echo != payload
        link.retries = 3
        recovered = 0
        for _ in range(pings):
            with contextlib.suppress(LinkError):  # all retries lost: counted as not recovered
                recovered += link.request("PING", payload=b"again").fields()["payload"] == b"again"
        link.retries = 20  # at 1e-2 per byte half the exchanges fail
        link.configure("passthrough", "F32")
        streamed, loss, resent = 0, "", link.retried
        try:
            inputs = (struct.pack("<4f", k, k, k, k) for k in range(samples))
            for k, reply in enumerate(link.pipeline(("SAMPLE", {"inputs": x}) for x in inputs)):
                if reply.fields()["outputs"] != struct.pack("<4f", k, k, k, k):
                    wrong += 1
                streamed += 1
        except LinkError as exc:
            loss = str(exc)
        resent = link.retried - resent
        replayed = link.stats()["replayed"] if not loss else -1
        injected = sum(link.port.counts.values())
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


def reset_recovery_s(board: str, what: int = 1) -> float:
    """From a reboot request (what=1) or a hang (2: the watchdog must act) to HELLO answered."""
    with open_board(board, timeout_s=2.0) as link:
        start = time.perf_counter()
        link.request("RESET", what=what)
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
        sc, make_board(board, faults=f"reboot_after={n // 2}"), console=Console(quiet=True)
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
    args = parser.parse_args(argv)
    console = make_console()
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
    wrong_total = 0
    for kind in CLASSES:
        for rate in RATES:
            r = measure(args.board, kind, rate, samples=args.samples)
            wrong_total += r["wrong"]
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
                r["loss"][:60] or "-",
            )
    console.print(t)
    console.print(f"board reset to ready again: {reset_recovery_s(args.board) * 1e3:.0f} ms")
    if args.board == "simavr":  # QEMU's mega2560 has no watchdog
        hang = reset_recovery_s(args.board, what=2)
        console.print(f"board hung, watchdog reset, ready again: {hang * 1e3:.0f} ms")
    console.print(f"a run with a board reset half-way: {resumed_run(args.board)}")
    return 1 if wrong_total else 0


if __name__ == "__main__":
    sys.exit(main())
