"""A short coverage-guided fuzz run of the message core under ASan and UBSan."""

import pytest

from vehil import fuzz


@pytest.mark.skipif(
    fuzz.clang() is None, reason="clang not installed (apt-get install clang libclang-rt-14-dev)"
)
def test_a_short_fuzz_run_finds_no_crash_and_covers_the_dispatcher(tmp_path) -> None:  # noqa: ANN001
    result = fuzz.run(5, jobs_dir=tmp_path)
    assert result.crashes == []
    assert result.executions > 10_000
    assert result.coverage > 200  # seeded with valid frames: the dispatcher is reached


def test_the_seed_corpus_holds_a_conversation_for_every_estimator_and_mode(tmp_path) -> None:  # noqa: ANN001
    from vehil import estimators

    n = fuzz.seed_corpus(tmp_path)
    expected = sum(len(s.modes) for s in estimators.estimators().values())
    assert n == 7 + expected  # and a CONFIG in parts
    assert (tmp_path / "config-parts").read_bytes().count(b"\x00") > 3  # several frames
