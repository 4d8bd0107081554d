"""Assembly kernels that only float32 paths use, which no bit-exact drive holds to their C
twins, fixmath's fx_mul_f at every shift, which the drives reach only a few of, and the
fixed-point kernels (fixmath's, the quarter car's strut, STLQF's) on every edge: a fixture
project (tests/fixtures/kernels) builds an image whose probe estimator runs a kernel on
each SAMPLE's operands, and its own check (check_kernels.py) holds the assembly on simavr
to the C twin on the native board and to Python's integers, on edge and random operands."""

import subprocess

import pytest
from fixture_projects import FIXTURES, build, project_pytest

from vehil.paths import BUILD_DIR

pytestmark = [pytest.mark.hil, pytest.mark.long]

PROJECT = FIXTURES / "kernels"
CACHE = BUILD_DIR / "kernels-fixture"  # kept between runs: the builds are incremental


@pytest.fixture(scope="module")
def project_built() -> subprocess.CompletedProcess:
    return build(PROJECT, CACHE)


def test_the_bfp24_kernels_on_simavr_give_the_c_twins_bits(project_built) -> None:  # noqa: ANN001
    done = project_pytest("check_kernels.py", PROJECT, CACHE)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "29 passed" in done.stdout
