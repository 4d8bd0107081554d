"""The profile model on a bridge output written by hand: parsing, segments, self and
inclusive cycles (recursion counted once), interrupts apart, collapsed stacks."""

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from vehil.fnprofile.elfmap import Function
from vehil.fnprofile.model import Profile

FUNCS = [
    Function("main", 0, 100, ""),
    Function("step", 100, 200, ""),
    Function("f", 200, 300, ""),
    Function("__mulsi3", 300, 320, "libgcc"),
    Function("__vector_25", 320, 340, ""),
]

# main -> step -> f -> f (recursion) -> __mulsi3; an RX interrupt lands in f.
OUTPUT = """N 0 -1 0
W 0 999 end
S 0 999 1
P 10 999
C
N 1 0 1
N 2 1 2
N 3 2 2
N 4 3 3
N 5 2 -26
N 6 5 4
W 0 100 end
S 0 4 1
S 1 30 1
S 2 20 1
S 3 10 1
S 4 6 2
W 1 130 end
S 0 4 1
S 1 30 1
S 2 20 1
S 3 10 1
S 4 6 2
S 5 0 1
S 6 30 1
P 102 60
P 204 60
C
"""


def _profile(tmp_path: Path) -> Profile:
    path = tmp_path / "profile.txt"
    path.write_text(OUTPUT)
    elf = SimpleNamespace(functions=FUNCS, line_at=lambda addr: None)
    return Profile.read(path, elf, "step", segment=1)  # type: ignore[arg-type]


def test_windows_of_the_segment_asked_for(tmp_path: Path) -> None:
    p = _profile(tmp_path)
    assert p.windows == 2
    assert p.window_cycles.tolist() == [70, 100]  # S lines, not the W's own total
    assert p.pc_cycles == {0x102: 60, 0x204: 60}


def test_self_inclusive_and_calls_per_window(tmp_path: Path) -> None:
    p = _profile(tmp_path)
    f = p.function("f")
    assert f is not None
    assert f.self.tolist() == [30, 30]
    assert f.inclusive.tolist() == [36, 66]  # recursion once; the interrupt in it counts
    assert f.calls.tolist() == [2, 2]
    step = p.function("step")
    assert step is not None and step.inclusive.tolist() == [66, 96]
    assert p.function("__mulsi3").label == "__mulsi3 [libgcc]"  # type: ignore[union-attr]
    assert "__divsf3" not in p and "f" in p
    assert np.array_equal(sum(s.self for s in p.function_stats()), p.window_cycles)


def test_interrupts_are_counted_apart(tmp_path: Path) -> None:
    p = _profile(tmp_path)
    assert p.interrupt_cycles.tolist() == [0, 30]
    assert {k: v.tolist() for k, v in p.interrupts().items()} == {"interrupt USART0_RX": [0, 30]}
    assert {k: v.tolist() for k, v in p.interrupt_entries().items()} == {
        "interrupt USART0_RX": [0, 1]
    }


def test_collapsed_stacks(tmp_path: Path) -> None:
    stacks = _profile(tmp_path).collapsed()
    assert stacks["main;step;f;f;__mulsi3 [libgcc]"] == 12
    assert stacks["main;step;f;interrupt USART0_RX;__vector_25"] == 30
    assert sum(stacks.values()) == 170


def test_files_for_flame_graph_tools(tmp_path: Path) -> None:
    from vehil.fnprofile.export import write_all

    p = _profile(tmp_path)
    files = write_all(p, tmp_path / "out", "a step")
    lines = files["collapsed"].read_text().splitlines()
    assert "main;step;f;interrupt USART0_RX;__vector_25 30" in lines
    doc = json.loads(files["speedscope"].read_text())
    prof = doc["profiles"][0]
    assert prof["type"] == "sampled" and sum(prof["weights"]) == prof["endValue"] == 170
    names = [f["name"] for f in doc["shared"]["frames"]]
    stacks = {
        ";".join(names[i] for i in s): w
        for s, w in zip(prof["samples"], prof["weights"], strict=True)
    }
    assert stacks == p.collapsed()
    assert files["flame"].read_bytes()[:4] == files["flame_median"].read_bytes()[:4] == b"\x89PNG"
    assert "| f | 30 | 30 | 30 | 36 | 51 | 66 | 2 | 2 | 35.3 % |" in files["markdown"].read_text()


def test_figures_for_json(tmp_path: Path) -> None:
    from vehil.fnprofile.tables import figures

    fig = figures(_profile(tmp_path))
    assert fig["per"] == "step" and fig["windows"] == 2
    f = next(x for x in fig["functions"] if x["name"] == "f")
    assert f["inclusive"] == {"min": 36.0, "median": 51.0, "max": 66.0}
    assert fig["interrupts"]["interrupt USART0_RX"]["max"] == 30.0
    json.dumps(fig)  # plain data


def test_the_median_window_and_its_own_stacks(tmp_path: Path) -> None:
    p = _profile(tmp_path)
    assert p.median_window == 0  # 70 and 100 cycles: the lower middle
    assert sum(p.collapsed(1).values()) == 100
    assert "main;step;f;interrupt USART0_RX;__vector_25" not in p.collapsed(0)
