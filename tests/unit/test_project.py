"""A user's project (vehil.toml) and packaged plug-ins (entry points): their specs,
plants and scenarios are found without living in vehil's package."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vehil import project

SPEC_MODULE = """
import numpy as np
from vehil.estimators import register
from vehil.estimators.base import EstimatorSpec, Param, Signal


class Blend:
    def __init__(self, p):
        self.k, self.x = p["k"], None

    def step(self, u):
        self.x = u[0] if self.x is None else self.x + self.k * (u[0] - self.x)
        return np.array([self.x])


register(EstimatorSpec(
    name="{name}", c_id={c_id}, title="first-order blend",
    inputs=(Signal("y", "1", q=24),), outputs=(Signal("y", "1", q=24),),
    params=(Param("k", "1", q=30, default=0.5, lo=0.0, hi=1.0),),
    reference=Blend,
))
"""

SCENARIO = """
[scenario]
title = "blend on a noisy sine"
duration = 1.0
sample_time = 0.01
[plant]
name = "noisy_sine"
[estimator]
name = "blend"
[tolerance.y]
abs = 1e-3
"""


def _vehil(cwd: Path, *argv: str, env: dict | None = None) -> subprocess.CompletedProcess:
    environ = {k: v for k, v in os.environ.items() if k != "VEHIL_PROJECT"}
    return subprocess.run(
        [sys.executable, "-m", "vehil", *argv],
        cwd=cwd,
        env={**environ, **(env or {})},
        capture_output=True,
        text=True,
        timeout=60,
    )


def _project(root: Path, toml: str) -> Path:
    (root / "specs").mkdir(parents=True)
    (root / "specs" / "blend.py").write_text(SPEC_MODULE.format(name="blend", c_id=200))
    (root / "scenarios" / "mine").mkdir(parents=True)
    (root / "scenarios" / "mine" / "blend-sine.toml").write_text(SCENARIO)
    (root / "vehil.toml").write_text(toml)
    return root


GOOD = '[project]\nname = "demo"\nestimators = ["specs/*.py"]\nscenarios = "scenarios"\n'


def test_a_project_s_specs_and_scenarios_are_found_from_any_folder_below_it(tmp_path) -> None:
    root = _project(tmp_path / "demo", GOOD)
    (root / "deeper").mkdir()
    listed = _vehil(root / "deeper", "estimators", "--json")
    assert listed.returncode == 0, listed.stderr
    blend = {e["name"]: e for e in json.loads(listed.stdout)}["blend"]
    assert blend["c_id"] == 200 and blend["params"][0]["q_format"] == "Q1.30"
    scenarios = _vehil(root, "scenarios", "--json")
    names = [s["name"] for s in json.loads(scenarios.stdout)]
    assert names[0] == "mine/blend-sine" and "acc/mixed" in names  # the project's, then vehil's
    assert scenarios.returncode == 0
    outside = _vehil(tmp_path, "estimators", "--json")
    assert "blend" not in {e["name"] for e in json.loads(outside.stdout)}


def test_a_packaged_plugin_registers_through_its_entry_point(tmp_path) -> None:
    site = tmp_path / "site"
    (site / "blend_plugin-1.0.dist-info").mkdir(parents=True)
    (site / "blend_plugin-1.0.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: blend-plugin\nVersion: 1.0\n"
    )
    (site / "blend_plugin-1.0.dist-info" / "entry_points.txt").write_text(
        "[vehil.estimators]\nblend = blend_plugin\n"
    )
    (site / "blend_plugin.py").write_text(SPEC_MODULE.format(name="plugged", c_id=201))
    listed = _vehil(tmp_path, "estimators", "plugged", "--json", env={"PYTHONPATH": str(site)})
    assert listed.returncode == 0, listed.stderr
    assert json.loads(listed.stdout)["title"] == "first-order blend"


@pytest.mark.parametrize(
    ("toml", "says"),
    [
        (
            '[project]\nestimator = ["x.py"]\n',
            r"project.estimator: unknown key; allowed: c_sources, estimators",
        ),
        (
            '[project]\nestimators = ["nothing/x.py"]\n',
            r"project.estimators: no file .*nothing/x.py",
        ),
        ('[project]\nestimators = "specs/blend.py"\n', r"project.estimators: a list of paths"),
        ('[project]\nscenarios = "nowhere"\n', r"project.scenarios: no folder"),
        ('[project]\nc_sources = ["nowhere"]\n', r"project.c_sources: no folder .*nowhere"),
        ("[project]\nimage = 3\n", r"project.image: estimator names"),
        ("[projet]\n", r"give one \[project\] table"),
    ],
)
def test_a_wrong_project_file_names_the_file_and_key(tmp_path, toml: str, says: str) -> None:
    root = _project(tmp_path / "p", toml)
    with pytest.raises(project.ProjectError, match=f"{root / 'vehil.toml'}: {says}"):
        project.parse(root / "vehil.toml")


def test_a_spec_module_that_fails_is_named(tmp_path) -> None:
    root = _project(tmp_path / "p", GOOD)
    (root / "specs" / "broken.py").write_text("raise RuntimeError('oops')\n")
    listed = _vehil(root, "estimators")
    assert listed.returncode == 2
    assert f"{root / 'specs' / 'broken.py'}: importing the estimator module failed" in (
        listed.stdout + listed.stderr
    )


def test_vehil_new_refuses_what_it_cannot_write_and_says_why(tmp_path) -> None:
    outside = _vehil(tmp_path, "new", "estimator", "smooth")
    assert outside.returncode == 2 and "run `vehil new project` first" in outside.stdout
    assert _vehil(tmp_path, "new", "project", "p").returncode == 0
    root = tmp_path / "p"
    assert project.parse(root / "vehil.toml").c_sources == ((root / "c").resolve(),)
    bad = _vehil(root, "new", "estimator", "Smooth-1")
    assert bad.returncode == 2 and "lower-case letters, digits and _" in bad.stdout
    taken = _vehil(root, "new", "estimator", "manf")
    assert taken.returncode == 2 and "'manf' is taken" in taken.stdout
    (root / "c" / "smooth.c").write_text("/* mine */\n")
    clash = _vehil(root, "new", "estimator", "smooth")
    assert clash.returncode == 2 and "smooth.c exists already: nothing written" in clash.stdout
    assert not (root / "specs" / "smooth.py").exists()
    again = _vehil(tmp_path, "new", "project", "p")
    assert again.returncode == 2 and "vehil.toml exists already" in again.stdout


def test_a_c_folder_with_white_space_in_its_path_is_refused_by_name(tmp_path) -> None:
    root = _project(tmp_path / "p", '[project]\nc_sources = ["my c"]\n')
    (root / "my c").mkdir()
    with pytest.raises(project.ProjectError, match=r"my c has white space in its path"):
        project.parse(root / "vehil.toml")
