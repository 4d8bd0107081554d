"""CSV files of named columns: a header of `name [unit]` cells and numbers below.

Logs replayed as a run's input and tables a plant reads (a recorded road, a GPS
trace) come this way; every problem names the file, and the column or line.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vehil.errors import VehilError

_HEADER = re.compile(r"^\s*(?P<name>[^\[\]]+?)\s*(?:\[(?P<unit>[^\]]*)\])?\s*$")


class LogError(VehilError):
    """A log cannot be used: the message names the file and the column or line."""


@dataclass
class Columns:
    values: dict[str, np.ndarray]
    units: dict[str, str]
    lines: np.ndarray | None = field(default=None)  # a CSV's file line of each row

    def place(self, row: int, column: str) -> str:
        """Where a value is, as the user finds it: a CSV's line, or the row's index."""
        where = f"line {self.lines[row]}" if self.lines is not None else f"sample {row}"
        return f"{where}, column {column}"


def read_csv(path: Path) -> Columns:
    """A CSV with a header of `name [unit]` cells (unit optional) and numbers below."""
    try:
        with path.open(newline="") as f:
            reader = csv.reader(f)
            rows, lines = [], []
            for row in reader:
                rows.append(row)
                lines.append(reader.line_num)
    except OSError as exc:
        raise LogError(f"{path}: cannot read: {exc.strerror}") from None
    if not rows:
        raise LogError(f"{path}: empty file; expected a header of `name [unit]` cells")
    names, units = [], {}
    for j, cell in enumerate(rows[0]):
        m = _HEADER.match(cell)
        if not m:
            raise LogError(
                f"{path}: line {lines[0]}, column {j + 1}: header cell {cell!r} is not "
                "`name [unit]`"
            )
        names.append(m["name"])
        units[m["name"]] = m["unit"] or ""
    data = np.empty((len(rows) - 1, len(names)))
    for i, row in enumerate(rows[1:]):
        line = lines[i + 1]
        if len(row) != len(names):
            raise LogError(
                f"{path}: line {line} has {len(row)} fields, the header {len(names)}"
                + (" (the file looks cut short)" if i == len(rows) - 2 else "")
            )
        for j, cell in enumerate(row):
            try:
                data[i, j] = float(cell)
            except ValueError:
                raise LogError(
                    f"{path}: line {line}, column {names[j]}: {cell!r} is not a number"
                ) from None
    return Columns({n: data[:, j] for j, n in enumerate(names)}, units, np.array(lines[1:]))
