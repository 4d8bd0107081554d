"""The fault campaign (`python -m vehil.faults_report --campaign`): its counts add up,
on the host's frame decoder alone and through a board."""

import json

import pytest

from vehil import faults_report
from vehil.faults_report import CODEC, campaign_row


@pytest.mark.parametrize("board", [CODEC, "native"])
@pytest.mark.parametrize("kind", ["drop", "insert"])
def test_every_exchange_a_fault_hit_is_detected_or_harmless(built, board, kind) -> None:  # noqa: ANN001
    row = campaign_row(board, kind, 0.02, faults=300, max_s=20.0)
    assert row.ended_by == "faults" and row.injected >= 300
    assert row.frames > row.hit > 0 and row.wrong == 0
    assert row.detected + row.harmless == row.hit  # each exchange hit: refused or right


def test_the_campaign_prints_a_row_per_board_class_and_rate_as_json(built, capsys) -> None:  # noqa: ANN001
    argv = ["--campaign", "--board", f"{CODEC},native", "--classes", "flip", "--rates", "0.01,0.02"]
    status = faults_report.main([*argv, "--faults-per-class", "50", "--seconds", "10", "--json"])
    rows = json.loads(capsys.readouterr().out)
    assert status == 0
    expected = [(b, "flip", rate) for b in (CODEC, "native") for rate in (0.01, 0.02)]
    assert [(r["board"], r["kind"], r["rate"]) for r in rows] == expected
    assert all(r["injected"] >= 50 and r["wrong"] == 0 for r in rows)


def test_a_board_that_does_not_start_is_a_row_that_says_so(capsys) -> None:  # noqa: ANN001
    argv = ["--campaign", "--board", "nonsense", "--classes", "drop", "--rates", "0.01", "--json"]
    assert faults_report.main(argv) == 2
    (row,) = json.loads(capsys.readouterr().out)
    assert row["ended_by"].startswith("error: no board 'nonsense'") and row["frames"] == 0
