"""Each estimator's C agrees with its Python spec (what `vehil build` checks), and a spec
that drifts from its C is caught, naming the field."""

import re
from dataclasses import replace

import pytest

from vehil.boards import open_board
from vehil.build.interface import check
from vehil.estimators import estimators, get


@pytest.fixture(scope="module")
def link(built):  # noqa: ANN001, ANN201
    with open_board("native") as link:
        yield link


def test_every_shipped_estimator_agrees_with_its_spec(link) -> None:
    assert check(link, estimators().values(), every_spec_built=True) == []


def _with_param(spec, name: str, **change):  # noqa: ANN001, ANN202
    return replace(
        spec, params=tuple(replace(p, **change) if p.name == name else p for p in spec.params)
    )


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (
            {"q": 16},
            r"manf\.params\.rg0 \(FIXED, q=16\): the spec's lo 0 is refused|"
            r"manf\.params\.rg0 \(FIXED, q=16\): .* accepted by the C",
        ),
        ({"hi": 50.0}, r"manf\.params\.rg0 \(F32, q=24\): .*past hi.* is accepted by the C"),
        ({"hi": 200.0}, r"manf\.params\.rg0 \(F32, q=24\): the spec's hi 200 is refused by the C"),
        ({"q": 8, "hi": 1e9}, r"manf\.params\.rg0: range \[0, 1e\+09\] does not fit its Q format"),
    ],
)
def test_a_range_or_q_format_that_drifted_is_named(link, change: dict, says: str) -> None:
    problems = check(link, [_with_param(get("manf"), "rg0", **change)], every_spec_built=False)
    assert problems and any(re.search(says, p) for p in problems), problems


def test_a_descriptor_that_drifted_is_named(link) -> None:
    spec = get("manf")
    fewer = replace(spec, params=spec.params[:-1], modes=("F32",))
    problems = check(link, [fewer], every_spec_built=False)
    assert (
        "manf: the C descriptor (id 20) has modes = ('F32', 'FIXED'), the spec ('F32',)" in problems
    )
    n = len(spec.params)
    assert f"manf: the C descriptor (id 20) has n_params = {n}, the spec {n - 1}" in problems


def test_a_rule_the_spec_lacks_is_named(link) -> None:
    spec = replace(get("stlqf"), rules=())
    problems = check(link, [spec], every_spec_built=False)
    assert any(
        "stlqf.params.a12 (F32, q=24): the spec's lo -100 is refused by the C" in p and "rules" in p
        for p in problems
    ), problems


def test_an_estimator_the_specs_do_not_name_is_named(link) -> None:
    problems = check(link, [get("manf")], every_spec_built=False)
    assert "acc_kf: the board has it (C id 10) but no spec names that id" in problems
