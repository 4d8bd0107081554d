"""The offline images' linker script: avr-ld's own with .data loaded after the start-up code."""

import re
import shutil

import pytest

from vehil.build.ldscript import (
    CODE_SECTION,
    RINGS_SECTION,
    LinkerScriptError,
    data_low,
    default_script,
)

pytestmark = pytest.mark.skipif(shutil.which("avr-ld") is None, reason="needs binutils-avr")


def _order(script: str) -> list[str]:
    return re.findall(r"^\s*(\.text|\.data|\.bss|\.code)\s*(?:ADDR\(.*\))?\s*:", script, re.M)


def test_data_loads_between_the_startup_code_and_the_rest() -> None:
    default = default_script("atmega2560")
    script = data_low(default)
    assert _order(default)[:3] == [".text", ".data", ".bss"]
    assert _order(script)[:4] == [".text", ".data", CODE_SECTION, ".bss"]
    start_up, code = script.split(f"  {CODE_SECTION}   :")
    assert "*(.init9)" in start_up and "*(.vectors)" in start_up
    assert "*(.text.*)" in code and "_etext = . ;" in code


def test_every_input_section_statement_is_kept_once() -> None:
    """Nothing lost or duplicated: the same statements, rearranged, and the rings first."""
    default = default_script("atmega2560")
    script = data_low(default)
    pattern = re.compile(r"\*\([^)]*\)")
    added = [f"*({RINGS_SECTION})"]
    assert sorted(pattern.findall(script)) == sorted(pattern.findall(default) + added)
    data = script[script.index("__data_start") :]
    assert pattern.findall(data)[0] == added[0]


def test_a_script_of_another_shape_is_refused() -> None:
    with pytest.raises(LinkerScriptError, match="expected shape"):
        data_low("SECTIONS { .text : { *(.text) } > text }\n")
