"""Plants and estimators share only vehil.spec and vehil.models, never each other's code."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import vehil

PACKAGE = Path(vehil.__file__).parent


def _imports(path: Path) -> list[str]:
    names = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.append(node.module)
            names += [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names += [a.name for a in node.names]
    return names


@pytest.mark.parametrize(("side", "other"), [("plants", "estimators"), ("estimators", "plants")])
def test_no_cross_import(side: str, other: str) -> None:
    modules = sorted((PACKAGE / side).glob("*.py"))
    assert modules, f"no modules under {side}/"
    bad = [
        f"{m.name} imports {name}"
        for m in modules
        for name in _imports(m)
        if name == f"vehil.{other}" or name.startswith(f"vehil.{other}.")
    ]
    assert not bad, f"{side}/ must not import from {other}/: " + "; ".join(bad)


def test_rule_sees_a_cross_import(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text("from vehil.estimators import base as b\nimport vehil.plants.sine\n")
    assert "vehil.estimators.base" in _imports(module)
    assert "vehil.plants.sine" in _imports(module)


def test_the_ev_truth_takes_only_data_from_the_shared_ev_module() -> None:
    """The EV plant steps its own car and tires: of vehil.models.ev4wd (which also holds
    the filters' model) it may use the car's data, never a model function."""
    from vehil.models import ev4wd

    tree = ast.parse((PACKAGE / "plants" / "ev4wd.py").read_text())
    used = {
        node.attr
        for node in ast.walk(tree)
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
        if node.value.id == "ev"
    }
    assert used, "plants/ev4wd.py no longer reads vehil.models.ev4wd as `ev`: update the test"
    calls = sorted(a for a in used if callable(getattr(ev4wd, a)) and a != "Car")
    assert not calls, f"plants/ev4wd.py calls the filters' model: {', '.join(calls)}"
