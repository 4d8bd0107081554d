"""Vendored code in the host builds: the opaque state slot's size check, and objects
rebuilt when a header they include changes, wherever it lives."""

import os
import subprocess
import time
from pathlib import Path

import pytest

from vehil.build import vendored
from vehil.build.native import c_flags
from vehil.build.objects import Unit, compile_units
from vehil.paths import DATA_ROOT

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "vendoring"


@pytest.mark.parametrize("compiler", [os.environ.get("CC", "cc"), "avr-gcc"])
def test_a_library_type_larger_than_its_slot_fails_the_build_naming_it(tmp_path, compiler) -> None:  # noqa: ANN001
    wrapper = tmp_path / "c"
    wrapper.mkdir()
    header = (FIXTURE / "c" / "abf_speed.h").read_text()
    (wrapper / "abf_speed.c").write_text((FIXTURE / "c" / "abf_speed.c").read_text())
    libs = vendored.libraries([FIXTURE])
    flags = [*c_flags(), "-I", str(DATA_ROOT / "firmware" / "lib"), *vendored.include_flags(libs)]
    if compiler == "avr-gcc":
        flags = [f for f in flags if "float" not in f and "double" not in f] + ["-mmcu=atmega2560"]

    def build(slot: int) -> subprocess.CompletedProcess:
        (wrapper / "abf_speed.h").write_text(
            header.replace("VEHIL_SLOT(24)", f"VEHIL_SLOT({slot})")
        )
        cmd = [compiler, *flags, "-c", str(wrapper / "abf_speed.c"), "-o", str(tmp_path / "w.o")]
        return subprocess.run(cmd, capture_output=True, text=True)

    assert build(24).returncode == 0  # the library's header (unused statics) warns nothing
    small = build(16)
    assert small.returncode != 0
    assert "ab_filter does not fit abf_speed_state_t.filter" in small.stderr


def test_an_object_is_rebuilt_when_a_header_it_includes_changes_anywhere(tmp_path) -> None:  # noqa: ANN001
    lib = tmp_path / "third_party" / "gain"
    lib.mkdir(parents=True)
    (lib / "gain.h").write_text("#define GAIN 2\n")
    source = tmp_path / "use.c"
    source.write_text('#include "gain.h"\nint gain(int x) { return GAIN * x; }\n')
    unit = Unit(source, ("-O2", "-I", str(lib)))
    cc = os.environ.get("CC", "cc")

    def build() -> float:
        [obj] = compile_units([unit], tmp_path / "obj", cc=cc, cxx="c++")
        return obj.stat().st_mtime_ns

    first = build()
    assert build() == first  # nothing changed: not compiled again
    time.sleep(0.01)
    (lib / "gain.h").write_text("#define GAIN 3\n")
    assert build() > first


ARDUINO_CLASS = """
#include <Arduino.h>
class Smoother {
public:
    explicit Smoother(float k) : k_(k), x_(0) {}
    float update(float u)
    {
        x_ += k_ * (constrain(u, -10.0f, 10.0f) - x_);
        byte b = lowByte(300);
        return x_ + abs(u) * PI + min(u, 1.0f) + max(u, 0.0f) + radians(u) + degrees(u) +
               sq(u) + (float)round(u) + (float)map(b, 0, 255, 0, 100) + (float)bit(2) + CALL;
    }
private:
    float k_, x_;
};
float use(float u) { Smoother s(0.5f); return s.update(u); }
"""


@pytest.mark.parametrize(
    "compiler",
    [os.environ.get("CXX", "c++"), "avr-g++ -mmcu=atmega2560"],
)
def test_an_arduino_class_builds_for_the_host_and_the_chip_but_not_with_a_clock(
    tmp_path, compiler: str
) -> None:  # noqa: ANN001
    from vehil.build.native import cxx_flags

    source = tmp_path / "smoother.cpp"

    def build(call: str) -> subprocess.CompletedProcess:
        source.write_text(ARDUINO_CLASS.replace("CALL", call))
        flags = cxx_flags()
        if compiler.startswith("avr"):  # avr-libc's maths is in double: the twin checks are native
            flags = [f for f in flags if "float" not in f and "double" not in f]
        cmd = [*compiler.split(), *flags, *vendored.include_flags([]), "-c", str(source)]
        return subprocess.run([*cmd, "-o", str(tmp_path / "s.o")], capture_output=True, text=True)

    built = build("0.0f")
    assert built.returncode == 0, built.stderr  # gnu++11, no exceptions or RTTI, -Werror
    clocked = build("(float)millis()")
    assert clocked.returncode != 0
    assert "an estimator has no clock" in clocked.stderr
