"""The command line on the native board: what it says, and its exit status."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from vehil import cli, record
from vehil.paths import DATA_ROOT
from vehil.report import _firmware

VEHIL = [sys.executable, "-m", "vehil"]


@pytest.fixture(scope="module")
def recorded(built, tmp_path_factory) -> Path:  # noqa: ANN001
    """A whole 10,000-sample run of `sine` on the native board."""
    out = tmp_path_factory.mktemp("sine")
    assert cli.main(["run", "sine", "--board", "native", "--out", str(out)]) == 0
    return out / "run.arrow"


def test_replaying_a_cut_recording_is_an_error_unless_accepted(recorded, tmp_path, capsys) -> None:  # noqa: ANN001
    cut = tmp_path / "cut.arrow"
    data = recorded.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    held = len(record.read(cut))
    assert 0 < held < 10_000
    assert cli.main(["replay", str(cut), "--scenario", "sine", "--board", "native"]) == 2
    said = capsys.readouterr().out
    assert "cut short" in said and "--accept-truncated" in said and "PASS" not in said
    out = tmp_path / "accepted"
    args = ["replay", str(cut), "--scenario", "sine", "--board", "native", "--out", str(out)]
    assert cli.main([*args, "--accept-truncated"]) == 0
    said = capsys.readouterr().out
    assert said.count("cut short") >= 2  # before the run and beside its verdict
    assert "cut short" in (out / "report.md").read_text()
    assert len(record.read(out / "run.arrow")) == held


def test_an_unknown_board_is_an_error_before_any_table(capsys) -> None:  # noqa: ANN001
    assert cli.main(["run", "sine", "--board", "nonsense"]) == 2
    said = capsys.readouterr().out
    assert said.lstrip().startswith("error: no board 'nonsense'")
    assert "simavr, " in said and "native" in said and "ports seen:" in said
    assert "RMSE" not in said and "samples" not in said


def test_tables_keep_their_full_width_off_a_terminal(built) -> None:  # noqa: ANN001
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    out = subprocess.run(
        [*VEHIL, "scenarios"], capture_output=True, text=True, check=True, env=env
    ).stdout
    assert max(len(line) for line in out.splitlines()) > 120
    assert "…" not in out


@pytest.mark.parametrize(
    "command",
    [
        ["scenarios"],
        ["info", "--board", "native"],
        ["ping", "--board", "native", "--count", "20"],
        ["demo", "--board", "native", "--samples", "50"],
        ["bench", "--boards", "native", "--scenario", "sine"],
        ["run", "sine", "--board", "native"],
        ["compare", "RUN", "RUN"],
        ["profile", "--board", "native", "--no-sweep", "--estimators", "passthrough"],
        ["reproduce", "manf"],  # a paper's tables, kept as rows
    ],
)
@pytest.mark.long  # `reproduce manf` runs the paper's drives
def test_every_command_that_prints_a_table_gives_json(recorded, command, capsys) -> None:  # noqa: ANN001
    command = [str(recorded) if c == "RUN" else c for c in command]
    cli.main([*command, "--json"])
    out = capsys.readouterr().out
    data = json.loads(out)  # stdout holds the JSON alone
    assert data
    if command[0] == "run":
        assert data["verdict"]["word"] == "PASS" and data["outputs"]["y"]["passed"] is True
    if command[0] == "reproduce":
        assert all(t["title"] and t["rows"] for t in data)


def test_compare_of_runs_of_other_drives_is_an_error_naming_the_difference(
    recorded,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
    capsys,  # noqa: ANN001
) -> None:
    other = tmp_path / "manf"
    args = ["run", "braking/manf-hard-stop", "--board", "native", "--out", str(other)]
    assert cli.main(args) in (0, 1)
    capsys.readouterr()
    assert cli.main(["compare", str(recorded), str(other)]) == 2
    said = " ".join(capsys.readouterr().out.split())
    assert (
        "(A, scenario 'sine') and" in said and "(B, 'manf-hard-stop') are not runs of one" in said
    )
    assert "their inputs differ: A's are y, B's omega_f, omega_r" in said
    assert "results differ" not in said and "│" not in said  # no table
    louder = tmp_path / "louder.toml"
    louder.write_text(
        (DATA_ROOT / "scenarios/synthetic/sine.toml")
        .read_text()
        .replace("amplitude = 2.0", "amplitude = 3.0")
        .replace("duration = 20.0", "duration = 0.1")
    )
    assert cli.main(["run", str(louder), "--board", "native", "--out", str(tmp_path / "l")]) == 0
    capsys.readouterr()
    assert cli.main(["compare", str(recorded), str(tmp_path / "l")]) == 2
    assert "input y differs from sample 1" in " ".join(capsys.readouterr().out.split())


def test_compare_with_a_shorter_run_says_which_and_how_it_ended(recorded, tmp_path, capsys) -> None:  # noqa: ANN001
    cut = tmp_path / "cut.arrow"
    data = recorded.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    held = len(record.read(cut))
    assert cli.main(["compare", str(recorded), str(cut)]) == 1
    said = " ".join(capsys.readouterr().out.split())
    assert (
        f"results differ; B holds {held:,} samples, the other 10,000 (its run: cut short)" in said
    )


def test_the_report_keeps_the_firmware_build_as_info_gives_it(recorded) -> None:  # noqa: ANN001
    assert _firmware({"build_id": 0x1234ABCD, "build_dirty": 1}) == "1234abcd+dirty"
    assert _firmware({"build_id": 0x1234ABCD, "build_dirty": 0}) == "1234abcd"
    info = record.read(recorded).header["board"]["info"]
    report = (recorded.parent / "report.md").read_text()
    assert f"- **firmware**: {_firmware(info)}\n" in report


def test_runs_that_name_no_folder_stay_out_of_the_checkout(built) -> None:  # noqa: ANN001
    import dataclasses

    from rich.console import Console

    from vehil import runner, scenario

    sc = dataclasses.replace(scenario.load("sine"), duration=0.1)
    run = runner.run(sc, "native", console=Console(quiet=True))
    assert run.recording is not None
    assert run.recording.resolve().is_relative_to(Path(os.environ["VEHIL_RUNS"]).resolve())
    assert not run.recording.resolve().is_relative_to(DATA_ROOT)


def test_several_scenarios_on_two_boards_at_once_give_one_table_and_the_worst_status(
    built,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
    write_short_sines,  # noqa: ANN001
) -> None:
    write_short_sines(tmp_path)
    out = tmp_path / "out"
    argv = [*VEHIL, "run", str(tmp_path / "sine-*.toml"), "--board", "native", "--jobs", "2"]
    proc = subprocess.run([*argv, "--out", str(out), "--json"], capture_output=True, text=True)
    assert proc.returncode == 1, proc.stderr  # FAIL is the worst of PASS, PASS, FAIL
    rows = {r["scenario"]: r for r in json.loads(proc.stdout)}
    assert {k: r["verdict"] for k, r in rows.items()} == {
        "sine-a": "PASS",
        "sine-b": "PASS",
        "sine-noisy": "FAIL",
    }
    assert all(r["samples"] == 500 for r in rows.values())
    for name in rows:  # each run its own folder, recording and report
        assert (out / name / "run.arrow").exists() and (out / name / "report.md").exists()
    assert cli.main(["run", str(tmp_path / "nothing-*.toml"), "--board", "native"]) == 2


def test_a_ping_size_the_board_cannot_echo_is_an_error_naming_its_range(built, capsys) -> None:  # noqa: ANN001
    assert cli.main(["ping", "--board", "native", "--size", "500", "--count", "2"]) == 2
    said = capsys.readouterr().out
    assert "error: --size 500: the board echoes 0..124 bytes (or -1: random sizes)" in said


@pytest.mark.parametrize(
    ("command", "error"),
    [
        (["run", "sine", "--out", "FILE"], "FILE: File exists (a file is where a folder should be"),
        (["sweep", "sweep-manf", "-n", "1", "--out", "FILE"], "FILE/drive-000: Not a directory"),
        (["profile", "--no-sweep", "--out", "FILE"], "FILE: File exists (a file is where a"),
        (["profile", "--no-sweep", "--compare", "FILE"], "FILE: not a profile.json"),
        (["profile", "--no-sweep", "--compare", "NONE"], "NONE: No such file or directory"),
    ],
)
def test_a_folder_or_file_that_cannot_be_used_is_an_error_before_the_work(
    built,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
    capsys,  # noqa: ANN001
    command,  # noqa: ANN001
    error,  # noqa: ANN001
) -> None:
    file = tmp_path / "a-file"
    file.write_text("not a folder")
    paths = {"FILE": str(file), "NONE": str(tmp_path / "none.json")}
    command = [paths.get(c, c) for c in command]
    assert cli.main([*command, "--board", "native"]) == 2
    said = " ".join(capsys.readouterr().out.split())
    assert f"error: {error}".replace("FILE", str(file)).replace("NONE", paths["NONE"]) in said
    assert "samples" not in said and "Traceback" not in said  # refused before any run


def test_pings_that_stop_on_a_lost_link_keep_the_figures_of_those_that_came_back(
    built,  # noqa: ANN001
    capsys,  # noqa: ANN001
) -> None:
    args = ["ping", "--board", "native", "--faults", "drop=0.05,seed=1", "--timeout", "0.1"]
    assert cli.main([*args, "--count", "50"]) == 2
    said = " ".join(capsys.readouterr().out.split())
    done = re.search(r"native: (\d+) PINGs", said)
    assert done and 0 < int(done[1]) < 50 and "round trip, host clock (ms)" in said
    assert "then lost: no reply to PING" in said
    assert said.endswith(f"error: the PINGs stopped after {done[1]} of 50")
