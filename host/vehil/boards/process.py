"""A board program (simavr bridge, QEMU) run as a child process that never outlives us."""

from __future__ import annotations

import contextlib
import os
import selectors
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import serial

from vehil.boards.base import Board, BoardOptions
from vehil.errors import BoardStartError

# Run by setpriv once the signal is set: a host that died before that (its child now
# has another parent) gets no signal, so the program is not started at all.
_IF_PARENT_LIVES = '[ "$PPID" = "$1" ] && shift && exec "$@"'


def _dies_with_parent(argv: list[str]) -> list[str]:
    """The command, made to get SIGKILL if the host dies without stopping it (SIGKILL, a
    timeout) by util-linux's setpriv, which sets it and execs the command. Not by a
    preexec_fn: Python code between fork and exec is unsafe in a host with threads (the
    frame maker's, or gRPC's, whose fork handlers restart its poller in the child, where
    closing the inherited descriptors made it abort the board before exec). Where there
    is no setpriv (not Linux), the host's normal stop() is all there is."""
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        return argv
    guard = ["/bin/sh", "-c", _IF_PARENT_LIVES, "sh", str(os.getpid())]
    return [setpriv, "--pdeathsig", "KILL", "--", *guard, *argv]


class BoardProcess:
    """Starts a command in its own process group; stderr goes to a file we can quote."""

    def __init__(
        self, argv: list[str], name: str, cwd: Path | None = None, pass_fds: tuple[int, ...] = ()
    ):
        self.argv = argv
        self.name = name
        self._stderr = tempfile.TemporaryFile()  # noqa: SIM115  (lives as long as the process)
        if shutil.which(argv[0]) is None:
            raise BoardStartError(f"cannot start {name}: {argv[0]}: no such program")
        try:
            self.proc = subprocess.Popen(
                _dies_with_parent(argv),
                stdin=subprocess.DEVNULL,
                cwd=cwd,
                stdout=subprocess.PIPE,
                stderr=self._stderr,
                start_new_session=True,  # Ctrl-C reaches us, and we stop it in order
                pass_fds=pass_fds,
            )
        except OSError as exc:
            raise BoardStartError(f"cannot start {name}: {argv[0]}: {exc.strerror}") from None

    def stderr_tail(self, lines: int = 15) -> str:
        self._stderr.seek(0)
        text = self._stderr.read().decode(errors="replace").strip().splitlines()
        return "\n".join(text[-lines:])

    def failure(self, what: str) -> BoardStartError:
        tail = self.stderr_tail()
        said = f"\n{self.name} said:\n{tail}" if tail else ""
        return BoardStartError(f"{self.name} {what} (command: {' '.join(self.argv)}){said}")

    def read_line(self, timeout_s: float) -> str:
        """The next stdout line, bounded in time; raises if the process dies first."""
        assert self.proc.stdout is not None
        deadline = time.monotonic() + timeout_s
        with selectors.DefaultSelector() as sel:
            sel.register(self.proc.stdout, selectors.EVENT_READ)
            while (remaining := deadline - time.monotonic()) > 0:
                if sel.select(remaining):
                    line = self.proc.stdout.readline()
                    if line:
                        return line.decode(errors="replace").strip()
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        self.proc.wait(remaining)  # its output closed: it is ending
                    break
        if not self.alive():
            raise self.failure(f"{self.state()} before it was ready")
        raise self.failure(f"printed nothing within {timeout_s:.0f} s")

    def alive(self) -> bool:
        return self.proc.poll() is None

    def state(self) -> str:
        """Running, exited with its status, or killed by a signal (a negative returncode)."""
        code = self.proc.poll()
        if code is None:
            return "is still running"
        if code < 0:
            return f"was killed by {signal.Signals(-code).name}"
        return f"exited with status {code}"

    def stop(self, grace_s: float = 2.0) -> None:
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGTERM)
                self.proc.wait(grace_s)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
            except ProcessLookupError:
                pass
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self._stderr.close()


class ProcessBoard(Board):
    """A board that is a child process (simavr's bridge, QEMU): its output quoted in
    errors, and stopped with the session."""

    def __init__(self, options: BoardOptions | None = None):
        super().__init__(options)
        self.process: BoardProcess | None = None

    def check_alive(self) -> None:
        if self.process is not None and not self.process.alive():
            raise self.process.failure("exited before accepting a connection")

    def port_error(self, url: str, exc: serial.SerialException) -> BoardStartError:
        if self.process is None:
            return super().port_error(url, exc)
        return self.process.failure(
            f"did not accept a connection on {url} within {self.connect_timeout_s:.0f} s ({exc})"
        )

    def diagnostics(self) -> str:
        if self.process is None:
            return ""
        tail = self.process.stderr_tail()
        return f"\n{self.name} {self.process.state()}" + (f"; it said:\n{tail}" if tail else "")

    def stop(self) -> None:
        if self.process is not None:
            self.process.stop()
            self.process = None
