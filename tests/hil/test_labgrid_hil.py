"""A board farm on labgrid, for real on loopback: a labgrid-coordinator, a labgrid-exporter
serving two virtual Megas (simavr with the Mega's bootloader, which resets on each open of
its pty as a Mega does on DTR) through ser2net as RFC 2217 network serial ports, and
vehil acquiring the places, running on them at once, and releasing them."""

import dataclasses
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from rich.console import Console

from vehil import flash, record, runner, scenario
from vehil.boards import BoardOptions, make_board
from vehil.boards.labgrid import Coordinator, LabgridBoard, LabgridOptions
from vehil.boards.process import BoardProcess
from vehil.boards.simavr import SimavrBootloaderBoard
from vehil.errors import BoardStartError
from vehil.paths import MEGA_BOOTLOADER_HEX

LABGRID_BIN = Path(sys.executable).with_name("labgrid-coordinator")  # beside our Python
pytestmark = [
    pytest.mark.hil,
    pytest.mark.long,
    pytest.mark.skipif(
        not (shutil.which("ser2net") or Path("/usr/sbin/ser2net").exists()),
        reason="needs Debian's ser2net (scripts/setup installs it)",
    ),
    pytest.mark.skipif(not LABGRID_BIN.exists(), reason="needs labgrid (pyproject)"),
    pytest.mark.skipif(not MEGA_BOOTLOADER_HEX.exists(), reason="needs arduino-core-avr"),
]
EXPORTER = "vehil-test"
PLACES = ("mega-a", "mega-b")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _flash_image(elf: Path, out: Path) -> Path:
    """The chip's whole flash with the firmware in it, as the bridge keeps it."""
    raw = out.with_suffix(".raw")
    subprocess.run(["avr-objcopy", "-O", "binary", "-R", ".eeprom", str(elf), str(raw)], check=True)
    code = raw.read_bytes()
    out.write_bytes(code + b"\xff" * (256 * 1024 - len(code)))
    return out


@dataclasses.dataclass
class Lab:
    address: str
    folder: Path

    def client(self, *args: str, user: str | None = None) -> str:
        env = os.environ | {"LG_COORDINATOR": self.address}
        if user:
            env["LG_USERNAME"] = user
        exe = LABGRID_BIN.with_name("labgrid-client")
        done = subprocess.run([str(exe), *args], env=env, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        return done.stdout

    def board(self, place: str, wait_s: float = 10.0) -> LabgridBoard:
        options = LabgridOptions(
            coordinator=self.address, wait_s=wait_s, usage_log=self.folder / "usage.jsonl"
        )
        board = make_board(f"labgrid:{place}", BoardOptions(timeout_s=2.0), labgrid=options)
        assert isinstance(board, LabgridBoard)
        return board

    def holder(self, place: str) -> str:
        shown = self.client("-p", place, "show")
        return next(
            line.split(":", 1)[1].strip() for line in shown.splitlines() if "acquired:" in line
        )


def _wait_listening(port: int, process: BoardProcess) -> None:
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        assert process.alive(), process.stderr_tail()
        time.sleep(0.1)
    raise AssertionError(f"{process.name} not listening: {process.stderr_tail()}")


@pytest.fixture(scope="module")
def lab(built, tmp_path_factory) -> Lab:  # noqa: ANN001
    folder = tmp_path_factory.mktemp("lab")
    boards = []
    config = []
    for place in PLACES:
        image = _flash_image(built["firmware"], folder / f"{place}.bin")
        board = SimavrBootloaderBoard(flash_image=image)
        config.append(f"{place}:\n  RawSerialPort:\n    port: {board.start()}\n    speed: 115200\n")
        boards.append(board)
    (folder / "exporter.yaml").write_text("".join(config))
    # the coordinator's own file of places, as `labgrid-client -p P create; add-match` leave it
    now = time.time()
    (folder / "places.yaml").write_text(
        "".join(
            f"{place}:\n  acquired: null\n  acquired_resources: []\n  aliases: []\n"
            f"  allowed: []\n  changed: {now}\n  comment: ''\n  created: {now}\n"
            f"  matches:\n  - cls: NetworkSerialPort\n    exporter: {EXPORTER}\n"
            f"    group: {place}\n    name: null\n    rename: null\n"
            "  reservation: null\n  tags: {}\n"
            for place in PLACES
        )
    )
    port = _free_port()
    address = f"127.0.0.1:{port}"
    processes = []
    try:
        # it keeps its places in its working folder
        coordinator = BoardProcess([str(LABGRID_BIN), "-l", address], "labgrid-coordinator", folder)
        processes.append(coordinator)
        _wait_listening(port, coordinator)
        exporter = BoardProcess(
            [
                str(LABGRID_BIN.with_name("labgrid-exporter")),
                "-c",
                address,
                "--name",
                EXPORTER,
                "--hostname",
                "127.0.0.1",
                str(folder / "exporter.yaml"),
            ],  # fmt: skip
            "labgrid-exporter",
        )
        processes.append(exporter)
        watch = Coordinator.attach(address)
        try:  # until the exporter has said what it serves
            deadline = time.monotonic() + 20
            while len(watch.session.resources.get(EXPORTER, {})) < len(PLACES):
                assert exporter.alive() and time.monotonic() < deadline, exporter.stderr_tail()
                time.sleep(0.1)
        finally:
            watch.detach()
        yield Lab(address, folder)
    finally:
        for p in reversed(processes):
            p.stop()
        for b in boards:
            b.stop()


def test_two_places_at_once_and_one_released_mid_run(lab: Lab) -> None:
    """Two scenarios on two places at the same time; the second place is taken away by
    a lab admin mid-run: that run fails saying so, its recording closed; the other
    completes; both places end released, and the usage log has both."""
    sine = dataclasses.replace(scenario.load("sine"), duration=6.0)  # 3,000 samples
    # 60,000 samples: ~10 s on a quiet host, so the kick always lands mid-run
    mixed = dataclasses.replace(scenario.load("mixed"), duration=600.0)
    runs: dict[str, runner.Run] = {}
    recordings = {p: lab.folder / p / "run.arrow" for p in PLACES}

    def go(place: str, sc: scenario.Scenario) -> None:
        quiet = Console(quiet=True)
        runs[place] = runner.run(sc, lab.board(place), recording=recordings[place], console=quiet)

    threads = [
        threading.Thread(target=go, args=(place, sc))
        for place, sc in zip(PLACES, (sine, mixed), strict=True)
    ]
    for t in threads:
        t.start()
    deadline = time.monotonic() + 60
    while not recordings["mega-b"].exists():  # written once the place is up
        assert time.monotonic() < deadline and threads[1].is_alive()
        time.sleep(0.1)
    time.sleep(1.0)
    lab.client("-p", "mega-b", "release", "--kick", user="labadmin")
    for t in threads:
        t.join(120)
    a, b = runs["mega-a"], runs["mega-b"]
    assert (a.ended, a.done) == ("completed", 3000), a.error
    assert b.ended == "failed" and 0 < b.done < 60_000
    assert "labgrid place mega-b was released while in use (now free)" in (b.error or "")
    rec = record.read(recordings["mega-b"])
    assert rec.end is not None and rec.end["ended"] == "failed" and len(rec) <= b.done
    assert lab.holder("mega-a") == "None" and lab.holder("mega-b") == "None"
    used = (lab.folder / "usage.jsonl").read_text()
    assert '"place": "mega-a"' in used and '"ended": "released"' in used
    assert '"ended": "lost: labgrid place mega-b was released while in use (now free)"' in used
    print(
        f"\nat once: mega-a {a.done / a.wall_s:.0f} samples/s (sine), "
        f"mega-b {b.done / b.wall_s:.0f} samples/s (mixed) until released"
    )


def test_a_place_held_by_someone_else_times_out_naming_them(lab: Lab) -> None:
    lab.client("-p", "mega-a", "acquire", user="alice")
    try:
        board = lab.board("mega-a", wait_s=1.0)
        start = time.monotonic()
        with pytest.raises(BoardStartError, match=r"mega-a is still held by \S+/alice after 1 s"):
            board.start()
        board.stop()
        assert time.monotonic() - start < 10
    finally:
        lab.client("-p", "mega-a", "release", user="alice")
    assert '"ended": "not acquired"' in (lab.folder / "usage.jsonl").read_text()


def test_avrdude_programs_through_the_place(lab: Lab, tmp_path: Path) -> None:
    """avrdude over the network port (a loopback relay to RFC 2217): the open resets the
    board into its bootloader, a page is written and read back the same."""
    page = tmp_path / "page.hex"
    data = bytes(range(256))
    records = [
        f":10{a:04X}00{data[a : a + 16].hex().upper()}"
        f"{(-(16 + (a >> 8) + (a & 255) + sum(data[a : a + 16]))) & 255:02X}"
        for a in range(0, 256, 16)
    ]
    page.write_text("\n".join([*records, ":00000001FF"]) + "\n")
    board = lab.board("mega-b")
    url = board.start()
    try:
        with board.programmer_port(url) as programmer:
            result = flash.run_avrdude(flash.avrdude_port(programmer), page, timeout_s=30)
    finally:
        board.stop()
    assert result.bytes == 256


def test_vehil_flash_to_a_place_the_coordinator_lacks_stops_before_building(
    lab: Lab,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from vehil import cli

    def build(*_: object) -> None:
        raise AssertionError("an image was built for a place that does not exist")

    monkeypatch.setattr(flash, "firmware_hex", build)
    monkeypatch.setenv("LG_COORDINATOR", lab.address)
    assert cli.main(["flash", "--board", "labgrid:mega-z"]) == 2
    said = " ".join(capsys.readouterr().out.split())
    assert f"no labgrid place 'mega-z' at {lab.address} (places: mega-a, mega-b)" in said
