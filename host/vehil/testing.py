"""pytest fixtures for HIL tests of your own (a pytest plugin, loaded automatically).

    def test_my_estimator_keeps_up(run_scenario):
        result = run_scenario("sine", board="qemu")
        result.assert_passed()

`--vehil-board NAME` picks the board for tests that do not name one (default simavr).

    def test_my_step_does_no_64_bit_division(profile_steps):
        profile = profile_steps("manf-hard-stop-fixed", samples=200, window=1)
        profile.assert_not_called("__udivmoddi4")
        profile.assert_self_at_most("manf_step", 1500)   # cycles in any one step
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from vehil.boards import BoardOptions, open_board
from vehil.compare import Figures
from vehil.link import Link


@dataclass
class ScenarioResult:
    """A finished run with its figures, its recording and its report folder."""

    run: Any
    figures: Figures
    recording: Path | None

    @property
    def passed(self) -> bool:
        return self.figures.passed

    def assert_passed(self) -> None:
        if self.passed:
            return
        from vehil.report import summary_table

        console = Console(width=160, record=True)
        console.print(summary_table(self.figures, self.run.scenario.name))
        why = str(self.figures.verdict)
        raise AssertionError(f"{why} (recording {self.recording})\n{console.export_text()}")


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--vehil-board", default="simavr", help="board for vehil HIL fixtures (default simavr)"
    )


@pytest.fixture
def vehil_board_name(request: pytest.FixtureRequest) -> str:
    return str(request.config.getoption("--vehil-board"))


@pytest.fixture
def board(vehil_board_name: str) -> Iterator[Link]:
    """A started board with its link open and INFO read; stopped after the test."""
    with open_board(vehil_board_name, BoardOptions(timeout_s=3.0)) as link:
        yield link


@pytest.fixture
def run_scenario(vehil_board_name: str, tmp_path: Path) -> Callable[..., ScenarioResult]:
    """run_scenario(NAME_OR_PATH_OR_SCENARIO, board=None, duration=None, **run options)."""
    from vehil import runner, scenario

    def _run(
        which: Any, board: str | None = None, duration: float | None = None, **options: Any
    ) -> ScenarioResult:
        sc = which if isinstance(which, scenario.Scenario) else scenario.load(which)
        if duration is not None:
            sc = dataclasses.replace(sc, duration=duration)
        name = board or vehil_board_name
        rec = tmp_path / f"{sc.name}-{name}.arrow"
        result = runner.run(sc, name, recording=rec, console=Console(quiet=True), **options)
        return ScenarioResult(result, result.figures, result.recording)

    return _run


@pytest.fixture
def profile_steps(tmp_path: Path) -> Callable[..., Any]:
    """profile_steps(NAME_OR_PATH_OR_SCENARIO, board="simavr", samples=None, window=None)
    -> vehil.fnprofile.Profile: every step's cycles per function, counted on simavr
    (window=1: stop-and-wait, so no receive interrupt lands in a step)."""
    from vehil import scenario
    from vehil.fnprofile import collect

    def _profile(
        which: Any, board: str = "simavr", samples: int | None = None, window: int | None = None
    ) -> Any:
        sc = which if isinstance(which, scenario.Scenario) else scenario.load(which)
        if samples is not None:
            sc = dataclasses.replace(sc, duration=min(sc.duration, samples * sc.sample_time))
        folder = tmp_path / f"profile-{sc.name}-{board}"
        return collect.scenario_steps(sc, board, window=window, folder=folder).profile

    return _profile
