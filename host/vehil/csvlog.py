"""CSV files of named columns: a header of `name [unit]` cells and numbers below.

Logs replayed as a run's input and tables a plant reads (a recorded road, a GPS
trace) come this way; every problem names the file, and the column or line.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from vehil import units
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


MISSING = frozenset({"", "-", "nan", "na", "n/a", "null", "none"})
_SUFFIX = re.compile(r"^(?P<name>.*?)\s*\((?P<unit>[^()]*)\)\s*$")


def header_cell(cell: str) -> tuple[str, str]:
    """A header cell's name and unit: `name [unit]`, or a trailing `(unit)` that is a
    unit (Torque's `Speed (OBD)(km/h)`: name `Speed (OBD)`, unit `km/h`)."""
    m = _HEADER.match(cell)
    if m and m["unit"] is not None:
        return m["name"], m["unit"]
    cell = cell.strip()
    s = _SUFFIX.match(cell)
    if s and s["name"] and units.known(s["unit"]):
        return s["name"], s["unit"]
    return cell, ""


@dataclass
class CsvColumns:
    """The columns a scenario maps, each with NaN where a cell is missing."""

    t: np.ndarray  # s from the first row, or the time column's own numbers
    t_unit: str  # "" for text time stamps (already s)
    lines: np.ndarray  # each row's line in the file
    values: dict[str, np.ndarray]
    units: dict[str, str]
    header: list[str]


def _stamp(cell: str, fmt: str | None) -> float:
    """A text time stamp in seconds since the epoch: `fmt` (strptime) or ISO 8601."""
    if fmt:
        return datetime.strptime(cell.strip(), fmt).timestamp()
    return datetime.fromisoformat(cell.strip()).timestamp()


def read_columns(
    path: Path,
    wanted: list[str],
    time: str,
    *,
    units_row: bool = False,
    time_format: str | None = None,
    delimiter: str = ",",
) -> CsvColumns:
    """Only the `wanted` columns and the time column of a CSV log. A cell in MISSING is
    NaN (that column has no sample on that row); any other cell that is not a number is
    refused with its line and column. Columns are found by name or by the whole header
    cell; a units row (asammdf's export) under the header gives units."""
    try:
        with path.open(newline="", encoding="utf-8-sig", errors="replace") as f:
            reader = csv.reader(f, delimiter=delimiter)
            rows = [(reader.line_num, row) for row in reader]
    except OSError as exc:
        raise LogError(f"{path}: cannot read: {exc.strerror}") from None
    if not rows:
        raise LogError(f"{path}: empty file; expected a header of `name [unit]` cells")
    head_line, head = rows[0]
    cells = [c.strip() for c in head]
    parsed = [header_cell(c) for c in cells]
    body = rows[1:]
    if units_row:
        if not body:
            raise LogError(f"{path}: no units row under the header (line {head_line + 1})")
        parsed = [(n, u.strip() or pu) for (n, pu), u in zip(parsed, body[0][1], strict=False)]
        body = body[1:]
    index: dict[str, int] = {}
    for j, (name, _) in enumerate(parsed):
        index.setdefault(name, j)
        index.setdefault(cells[j], j)

    def find(name: str, what: str, hint: str = "") -> int:
        if name not in index:
            shown = ", ".join(repr(n) for n, _ in parsed[:40])
            raise LogError(f"{path}: no {what} {name!r}{hint}; columns: {shown}")
        return index[name]

    jt = find(time, "time column", " (set [log] time, or a preset)")
    cols = {name: find(name, "column") for name in wanted}
    n = len(body)
    t = np.full(n, np.nan)
    values = {name: np.full(n, np.nan) for name in cols}
    lines = np.array([line for line, _ in body], dtype=np.int64)
    text_time = False
    for i, (line, row) in enumerate(body):
        if len(row) < len(cells) and not (len(row) == 1 and not row[0].strip()):
            raise LogError(
                f"{path}: line {line} has {len(row)} fields, the header {len(cells)}"
                + (" (the file looks cut short)" if i == n - 1 else "")
            )
        if not row or (len(row) == 1 and not row[0].strip()):
            continue  # a blank line
        if any(c.strip() for c in row[len(cells) :]):
            raise LogError(
                f"{path}: line {line} has {len(row)} fields, the header {len(cells)}: a value "
                "with an unquoted comma (a decimal comma?) shifts every column after it; "
                "quote such values, or export with a decimal point"
            )
        cell = row[jt].strip()
        if cell.lower() not in MISSING:
            try:
                t[i] = float(cell)
            except ValueError:
                try:
                    t[i] = _stamp(cell, time_format)
                    text_time = True
                except ValueError:
                    how = f"`{time_format}`" if time_format else "ISO 8601"
                    raise LogError(
                        f"{path}: line {line}, column {time}: {cell!r} is neither a number nor "
                        f"a time stamp in {how}; set [log] time_format (strptime codes)"
                    ) from None
        for name, j in cols.items():
            cell = row[j].strip()
            if cell.lower() in MISSING:
                continue
            try:
                values[name][i] = float(cell)
            except ValueError:
                raise LogError(
                    f"{path}: line {line}, column {name}: {cell!r} is not a number (missing "
                    f"values may be {', '.join(repr(m) for m in sorted(MISSING))})"
                ) from None
    if text_time:
        t = t - np.nanmin(t)
    return CsvColumns(
        t=t,
        t_unit="s" if text_time else parsed[jt][1],
        lines=lines,
        values=values,
        units={name: parsed[j][1] for name, j in cols.items()},
        header=cells,
    )
