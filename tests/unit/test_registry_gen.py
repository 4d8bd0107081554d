"""The generated estimator registry: estimators found by their headers, an image's set
chosen by name, errors that say what is wrong."""

from pathlib import Path

import pytest

from vehil.build import registry
from vehil.errors import BuildError


def test_every_estimator_header_is_found_and_all_minus_names_leaves_them_out() -> None:
    known = registry.available()
    assert {"passthrough", "manf", "acc_kf", "ev_ekf", "ev_ukf"} <= set(known)
    default = registry.select("all -ev_ekf -ev_ukf")
    assert default[0] == "passthrough" and "ev_ekf" not in default and "manf" in default
    assert registry.select("manf") == ["passthrough", "manf"]


def test_the_header_holds_the_states_and_descriptors_of_the_image_only() -> None:
    text = registry.render(["passthrough", "manf"])
    assert '#include "estimators/manf.h"' in text and "manf_state_t manf; \\" in text
    assert "&manf_estimator, \\" in text and "acc_kf" not in text
    assert text.endswith("\n\n")


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("manf nope", r"no estimator 'nope' in .*estimators \(there: acc_kf"),
        ("all -nope", r"no estimator 'nope'"),
        ("all manf", r"after `all` only `-name` may follow"),
    ],
)
def test_a_wrong_selection_is_named(spec: str, says: str) -> None:
    with pytest.raises(BuildError, match=says):
        registry.select(spec)


def test_a_descriptor_without_its_state_type_is_named(tmp_path: Path) -> None:
    (tmp_path / "mine.h").write_text("extern const ROM estimator_t mine_estimator;\n")
    with pytest.raises(BuildError, match=r"mine.h: declares mine_estimator but no mine_state_t"):
        registry.available([tmp_path])
