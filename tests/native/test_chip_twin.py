"""The native build refuses C that would compute in double: 32 bits on the AVR, 64 on
the host, so such code would make the native board stop being the chip's twin."""

import os
import subprocess

import pytest

from vehil.build.native import c_flags


def _compile(tmp_path, body: str) -> subprocess.CompletedProcess:  # noqa: ANN001
    src = tmp_path / "filter.c"
    src.write_text("#include <math.h>\n" + body)
    cmd = [os.environ.get("CC", "cc"), *c_flags(), "-c", str(src), "-o", str(tmp_path / "f.o")]
    return subprocess.run(cmd, capture_output=True, text=True)


@pytest.mark.parametrize(
    ("body", "flag"),
    [
        ("float gain(float x, double k) { return (float)(x * k); }\n", "double-promotion"),
        ("float gain(float x) { return x * 0.5; }\n", "float-conversion"),
        ("float gain(float x) { return sin(x) * 0.5f; }\n", "float-conversion"),
    ],
)
def test_arithmetic_in_double_is_refused_naming_the_flag(tmp_path, body: str, flag: str) -> None:
    built = _compile(tmp_path, body)
    assert built.returncode != 0 and f"-Werror={flag}" in built.stderr, built.stderr


def test_the_same_in_float_builds(tmp_path) -> None:  # noqa: ANN001
    built = _compile(tmp_path, "float gain(float x) { return sinf(x) * 0.5f; }\n")
    assert built.returncode == 0, built.stderr
