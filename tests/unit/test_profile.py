"""Profile arithmetic: UART settings as the datasheet gives them, regressions found."""

import pytest

from vehil.profile import compare_figures, uart_setting


@pytest.mark.parametrize(
    ("baud", "ubrr", "error_pct"),
    [
        (115200, 16, 2.12),
        (230400, 8, -3.55),
        (250000, 7, 0.0),
        (1_000_000, 1, 0.0),
        (2_000_000, 0, 0.0),
        (9600, 207, 0.16),
    ],
)
def test_uart_settings_match_the_datasheet(baud, ubrr, error_pct) -> None:  # noqa: ANN001
    s = uart_setting(baud)
    assert s.ubrr == ubrr
    assert s.error_pct == pytest.approx(error_pct, abs=0.01)


def test_compare_names_what_got_slower_and_only_that() -> None:
    def figures(rtt: float, cycles: float) -> dict:
        return {
            "sweep": [{"baud": 115200, "latency": [{"size": 16, "rtt_ms": {"p50": rtt}}]}],
            "estimators": [{"estimator": "kf", "mode": "F32", "cycles": {"median": cycles}}],
        }

    assert compare_figures(figures(4.0, 1000), figures(4.2, 1050)) == []
    slower = compare_figures(figures(4.0, 1000), figures(5.0, 1500))
    assert len(slower) == 2
    assert "115200 baud, 16 B: 4.000 -> 5.000 ms (+25 %)" in slower[0]
    assert "kf F32: median 1000 -> 1500 cycles (+50 %)" in slower[1]


def test_every_budget_scenario_is_a_shipped_drive_of_its_estimator() -> None:
    from vehil import estimators, scenario

    for name, spec in estimators.estimators().items():
        if spec.budget_scenario:
            assert scenario.load(spec.budget_scenario).estimator.name == name
