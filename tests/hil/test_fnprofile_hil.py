"""`vehil profile --functions` on simavr: the bridge's counts against RESULT, a step of
known shape, interrupts apart from the step's own code, and the pytest-facing API."""

import numpy as np
import pytest

from vehil import scenario
from vehil.fnprofile import collect, tables

pytestmark = pytest.mark.hil

MANF = "manf-hard-stop-fixed"


def _steps(tmp_path, window, samples=150, name=MANF):  # noqa: ANN001, ANN202
    import dataclasses

    sc = scenario.load(name)
    sc = dataclasses.replace(sc, duration=samples * sc.sample_time)
    return collect.scenario_steps(sc, window=window, folder=tmp_path / f"w{window}")


def test_every_cycle_of_a_step_is_counted_once_and_matches_result(tmp_path) -> None:  # noqa: ANN001
    # float32's step, which calls libm's helpers (FIXED's has every product inline)
    res = _steps(tmp_path, window=1, name="manf-hard-stop")
    p = res.profile
    assert p.windows == len(res.run.cycles) == 150
    # RESULT counts from the probe's read of Timer1 to the next one, less the probe's
    # own cost; the window is the step's call: they differ by the same few cycles.
    # A Timer1 overflow that lands between the two (rarely) adds its cycles to RESULT.
    d = res.run.cycles - p.window_cycles
    base = int(np.median(d))
    assert 0 < base < 64 and (d >= base).all() and (d == base).mean() > 0.95
    stats = p.function_stats()
    assert np.array_equal(sum(s.self for s in stats), p.window_cycles)  # interrupts' code too
    assert sum(p.collapsed().values()) == p.window_cycles.sum()
    step = p.function("manf_step")
    assert step is not None and (step.calls == 1).all()
    assert np.array_equal(step.inclusive + 4, p.window_cycles)  # and the ICALL, in main
    # the step's helpers by name: the project's own, and the library's named as such
    assert {s.library for s in stats if s.self.any()} >= {"", "libm"}
    assert all(s.name.startswith("__") for s in stats if s.library in ("libgcc", "libm"))


def test_lockstep_interrupts_are_apart_from_the_steps_own_code(tmp_path) -> None:  # noqa: ANN001
    alone_run = _steps(tmp_path, window=1)
    piped_run = _steps(tmp_path, window=None)
    alone, piped = alone_run.profile, piped_run.profile
    irq = piped.interrupts()
    assert irq["interrupt USART0_RX"].sum() > 0  # frames behind the step arrived during it
    # The same inputs: the step's own code takes the same cycles whatever lands in it.
    own = [p.window_cycles - p.interrupt_cycles for p in (alone, piped)]
    assert np.array_equal(own[0], own[1])
    # and RESULT says so: the board leaves the UART interrupts out of a step's cycles
    # (without that, MANF FIXED's read ~29 % more in lockstep)
    medians = [float(np.median(r.run.cycles)) for r in (alone_run, piped_run)]
    assert medians[1] == pytest.approx(medians[0], rel=0.05)


def test_a_step_of_known_shape_gives_the_expected_table(tmp_path) -> None:  # noqa: ANN001
    """passthrough's step copies its input with avr-libc's memcpy, once: 12 cycles and
    8 a byte (ld 2, st 2, subi, sbci, brcc 2)."""
    s = collect.session("simavr", "step", tmp_path)
    sizes = [4, 8, 16, 40, 4]
    with s.board("simavr").session() as link:
        link.configure("passthrough", "F32")
        for n in sizes:
            link.request("SAMPLE", inputs=bytes(range(n)))
    p = s.read()
    memcpy, step = p.function("memcpy"), p.function("passthrough_step")
    assert memcpy is not None and step is not None
    assert memcpy.library == "avr-libc"
    assert memcpy.calls.tolist() == [1] * len(sizes)
    assert memcpy.self.tolist() == [12 + 8 * n for n in sizes]
    assert len(set(step.self.tolist())) == 1  # no branch in it
    assert np.array_equal(step.inclusive, step.self + memcpy.self)


def test_a_users_test_asserts_on_functions(profile_steps) -> None:  # noqa: ANN001
    from vehil.fnprofile import ProfileError

    p = profile_steps(MANF, samples=20, window=1)
    p.assert_not_called("__udivmoddi4")
    p.assert_self_at_most("manf_step", 100_000)
    with pytest.raises(ProfileError, match="manf_step ran in 20 of 20 steps"):
        p.assert_not_called("manf_step")
    with pytest.raises(ProfileError, match="manf_step: .* self cycles in one step, more than 10"):
        p.assert_self_at_most("manf_step", 10)


def test_the_link_frame_path_per_ping(tmp_path) -> None:  # noqa: ANN001
    from vehil.protocol.frame import encode
    from vehil.protocol.schema import SCHEMA

    frames = collect.pings(size=16, count=30, folder=tmp_path / "frame")
    assert frames.windows == 30  # one window a PING: the frame's handling and its reply
    whole = collect.pings(size=16, count=30, what="exchange", folder=tmp_path / "exchange")
    # one receive interrupt a byte of the request on the wire
    request = encode(SCHEMA.messages["PING"].type, 1, bytes(16))
    assert whole.interrupt_entries()["interrupt USART0_RX"].tolist() == [30 * len(request)]
    # everything the frame path does happens in the exchange too
    assert whole.window_cycles[0] / 30 > np.median(frames.window_cycles)
    idle = whole.function(collect.IDLE_FUNCTION)  # the firmware's wait for bytes
    assert idle is not None and idle.self[0] > 0
    # every instruction's cycles are in the window, the dispatch loop's own too: main
    # runs between its calls, only ever returned to (the bridge once dropped a frame
    # that nothing called or jumped into during the window)
    assert sum(whole.pc_cycles.values()) == whole.window_cycles.sum()
    main = whole.function("main")
    assert main is not None and main.self[0] > 30 * 100


def test_vehil_run_profile_puts_the_flame_graph_in_the_report(tmp_path) -> None:  # noqa: ANN001
    from vehil import cli

    short = tmp_path / "sine-short.toml"  # sine, one second of it
    short.write_text(scenario.find("sine").read_text().replace("duration = 20.0", "duration = 1.0"))
    assert cli.main(["run", str(short), "--profile", "--out", str(tmp_path)]) == 0
    folder = tmp_path / "profile"
    files = ("flame.png", "flame-median.png", "profile.md", "stacks.collapsed")
    for name in (*files, "profile.speedscope.json"):
        assert (folder / name).stat().st_size > 0
    assert "![flame graph](profile/flame.png)" in (tmp_path / "report.md").read_text()
    assert "passthrough_step" in (folder / "profile.md").read_text()


def test_an_exchange_by_part_grows_with_its_bytes(tmp_path) -> None:  # noqa: ANN001
    """Each payload byte goes both ways: through the CRC twice (21 cycles each), once
    through each UART interrupt (39 received, 34 sent, as simavr counts them: it does
    not charge the chip's 5-cycle interrupt response)."""
    parts = {
        size: tables.exchange_parts(
            collect.pings(size=size, count=20, what="exchange", folder=tmp_path / f"p{size}")
        )
        for size in (16, 64)
    }
    slope = {k: (parts[64][k] - parts[16][k]) / 48 for k in parts[16]}
    assert slope["CRC-32C"] == pytest.approx(42, abs=0.5)
    assert slope["RX interrupts"] == pytest.approx(39, abs=0.5)
    assert slope["TX interrupts"] == pytest.approx(34, abs=0.5)
    assert sum(parts[16][k] for k in tables.EXCHANGE_PARTS[:-1]) == pytest.approx(
        parts[16]["not waiting"]
    )


def test_profiles_go_where_runs_go_or_where_out_says(tmp_path, monkeypatch) -> None:  # noqa: ANN001
    """$VEHIL_RUNS (or runs/) when no folder is named, --out exactly as given."""
    from vehil import cli

    monkeypatch.setenv("VEHIL_RUNS", str(tmp_path / "runs"))
    monkeypatch.chdir(tmp_path)
    assert cli.main(["profile", "--functions", "--ping", "16", "--count", "5"]) == 0
    assert (tmp_path / "runs/profile-functions-ping16-frame-simavr/profile.md").exists()
    out = tmp_path / "mine"
    args = ["profile", "--functions", "sine", "--samples", "20", "--per", "run", "--out", str(out)]
    assert cli.main(args) == 0
    assert (out / "profile.md").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine", "runs"]
