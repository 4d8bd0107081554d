"""CSV files of named columns: a header of `name [unit]` cells and numbers below.

Logs replayed as a run's input and tables a plant reads (a recorded road, a GPS
trace) come this way; every problem names the file, and the column or line.
"""

from __future__ import annotations

import codecs
import csv
import io
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import datetime
from datetime import time as time_of_day
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


def read_csv(path: Path, *, delimiter: str | None = None, decimal: str | None = None) -> Columns:
    """A CSV with a header of `name [unit]` cells (unit optional) and numbers below, in
    the file's own delimiter and decimal sign (see `read_table`)."""
    rows, _ = read_table(path, delimiter)
    head_line, head = rows[0]
    names, units = [], {}
    for j, cell in enumerate(head):
        m = _HEADER.match(cell)
        if not m:
            raise LogError(
                f"{path}: line {head_line}, column {j + 1}: header cell {cell!r} is not "
                "`name [unit]`"
            )
        names.append(m["name"])
        units[m["name"]] = m["unit"] or ""
    body = [(line, row) for line, row in rows[1:] if not _blank(row)]
    dec = decimal_sign(
        path, ((line, names[j], c) for line, row in body for j, c in enumerate(row)), decimal
    )
    data = np.empty((len(body), len(names)))
    for i, (line, row) in enumerate(body):
        if len(row) != len(names):
            raise LogError(
                f"{path}: line {line} has {len(row)} fields, the header {len(names)}"
                + (" (the file looks cut short)" if i == len(body) - 1 else "")
            )
        for j, cell in enumerate(row):
            try:
                data[i, j] = number(cell, dec)
            except ValueError as exc:
                raise LogError(f"{path}: line {line}, column {names[j]}: {exc}") from None
    lines = np.array([line for line, _ in body])
    return Columns({n: data[:, j] for j, n in enumerate(names)}, units, lines)


# Loggers' and spreadsheets' field separators; a file's is the one that splits its header.
DELIMITERS = (",", ";", "\t", "|")
_SEP_LINE = re.compile(r"^sep=(.)$")  # Excel's first line naming the delimiter
_SAMPLED = 200  # data rows that settle a delimiter the header leaves open


def _text(path: Path) -> str:
    """The file's text: UTF-8 or UTF-16 by their byte-order mark, UTF-8, or else Windows'
    ANSI code page (cp1252: Excel's "CSV" on Windows writes ° and ² in it)."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise LogError(f"{path}: cannot read: {exc.strerror}") from None
    if raw.startswith(codecs.BOM_UTF8):
        return raw[len(codecs.BOM_UTF8) :].decode("utf-8", errors="replace")
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        return raw.decode("utf-16", errors="replace")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("cp1252", errors="replace")


def _blank(row: list[str]) -> bool:
    return not any(c.strip() for c in row)


def _split(lines: list[str], delimiter: str) -> list[list[str]]:
    return list(csv.reader(lines, delimiter=delimiter))


def read_table(path: Path, delimiter: str | None = None) -> tuple[list[tuple[int, list[str]]], str]:
    """The file's rows with their line numbers (the header first), and its delimiter: the
    one given, Excel's `sep=` line, or the one of DELIMITERS that splits the header into
    columns; where several do, the one that splits the first rows as it splits the
    header. A file they leave open is refused, saying how each splits it."""
    text = _text(path)
    lines = text.splitlines(keepends=True)
    skip = 0
    if lines and (m := _SEP_LINE.match(lines[0].strip())):
        delimiter, skip = delimiter or m[1], 1
    if len(lines) <= skip:
        raise LogError(f"{path}: empty file; expected a header of `name [unit]` cells")
    if delimiter is None:
        delimiter = _delimiter(path, lines[skip : skip + 1 + _SAMPLED], skip + 1)
    reader = csv.reader(io.StringIO("".join(lines[skip:]), newline=""), delimiter=delimiter)
    rows = [(reader.line_num + skip, row) for row in reader]
    if not rows or _blank(rows[0][1]):
        raise LogError(f"{path}: empty file; expected a header of `name [unit]` cells")
    return rows, delimiter


def _delimiter(path: Path, lines: list[str], first: int) -> str:
    heads = {d: len(_split(lines[:1], d)[0]) for d in DELIMITERS}
    split = [d for d, n in heads.items() if n > 1]
    if len(split) <= 1:
        return split[0] if split else ","  # one column: any delimiter reads it
    sample = lines[1:-1] or lines[1:]  # the last line may be cut short
    agree = [d for d in split if all(_blank(r) or len(r) == heads[d] for r in _split(sample, d))]
    if len(agree) == 1:
        return agree[0]
    shown = " and ".join(f"{_NAMES[d]} into {heads[d]}" for d in split)
    rows = "split alike by each" if agree else "split like it by none"
    raise LogError(
        f"{path}: line {first}: the header splits {shown} columns, and the first rows "
        f'{rows}: say which delimiter the file uses: [log] delimiter = ";" (or ",", "\\t", "|")'
    )


_NAMES = {",": "by ','", ";": "by ';'", "\t": "by tab", "|": "by '|'"}

# Numbers by their decimal sign: `1,5` has a comma; `1,234` may be 1.234 or 1234 (a
# thousands separator), so it settles nothing on its own.
_COMMA_NUMBER = re.compile(r"[+-]?\d*,\d+(?:[eE][+-]?\d+)?")
_GROUPED = re.compile(r"[+-]?[1-9]\d{0,2}(?:,\d{3})+")
_POINT_NUMBER = re.compile(r"[+-]?(?:\d*\.\d+|\d+\.)(?:[eE][+-]?\d+)?")


def decimal_sign(path: Path, cells: Iterable[tuple[int, str, str]], given: str | None) -> str:
    """The file's decimal sign, from all its numbers (line, column, cell) at once: a comma
    where some have one and none a point; a file with both, or whose only commas may be
    thousands separators, is refused, naming a cell of each."""
    if given is not None:
        return given
    comma = point = grouped = None
    for line, column, cell in cells:
        c = cell.strip()
        if _GROUPED.fullmatch(c):
            grouped = grouped or (line, column, c)
        elif comma is None and _COMMA_NUMBER.fullmatch(c):
            comma = (line, column, c)
        elif point is None and _POINT_NUMBER.fullmatch(c):
            point = (line, column, c)
        if comma and point:
            raise LogError(
                f"{path}: numbers with a decimal comma (line {comma[0]}, column {comma[1]}: "
                f"{comma[2]!r}) and with a decimal point (line {point[0]}, column {point[1]}: "
                f"{point[2]!r}): export the file again with one decimal sign"
            )
    if comma:
        return ","
    if grouped and not point:
        line, column, c = grouped
        raise LogError(
            f"{path}: line {line}, column {column}: {c!r} is {c.replace(',', '.')} with a "
            f"decimal comma or {c.replace(',', '')} with a thousands separator, and no other "
            'number says which: set [log] decimal = "," or "."'
        )
    return "."


def number(cell: str, decimal: str = ".") -> float:
    """A cell's number in a file whose decimal sign is `decimal`; ValueError says why not."""
    c = cell.strip()
    other = "." if decimal == "," else ","
    if other in c:
        raise ValueError(
            f"{c!r} is not a number in this file, whose decimal sign is {decimal!r}"
            + (" (a thousands separator?)" if _GROUPED.fullmatch(c) else "")
        )
    try:
        return float(c.replace(",", ".") if decimal == "," else c)
    except ValueError:
        raise ValueError(f"{c!r} is not a number") from None


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


_DATED = ("%d", "%j", "%c", "%x", "%s")  # strptime codes that give the day


def _stamp(cell: str, fmt: str | None) -> tuple[float, bool]:
    """A text time stamp in seconds: since the epoch (`fmt`, strptime codes, or ISO 8601
    with a date), or since midnight (a time of day, ISO or `fmt` with no day); and
    whether it is a time of day, which wraps at midnight."""
    c = cell.strip()
    if fmt:
        return datetime.strptime(c, fmt).timestamp(), not any(d in fmt for d in _DATED)
    try:
        return datetime.fromisoformat(c).timestamp(), False
    except ValueError:
        t = time_of_day.fromisoformat(c)
        return t.hour * 3600 + t.minute * 60 + t.second + t.microsecond * 1e-6, True


def _past_midnight(t: np.ndarray) -> np.ndarray:
    """Times of day with a day added at each step back of over 12 h: a log that runs
    past midnight."""
    ok = ~np.isnan(t)
    days = np.cumsum(np.r_[0, np.diff(t[ok]) < -43200])
    out = t.copy()
    out[ok] += 86400.0 * days
    return out


def _is_units_row(row: list[str], time: int, decimal: str) -> bool:
    """A row under the header of units and blanks (`s`, `[km/h]`, `1`) whose time cell is
    a unit and no number, as the time cell of a row of data is."""
    if time >= len(row):
        return False
    try:
        number(row[time], decimal)
    except ValueError:
        cells = [_unbracketed(c) for c in row if c.strip()]
        return bool(row[time].strip()) and all(units.known(c) for c in cells)
    return False


def _unbracketed(unit: str) -> str:
    u = unit.strip()
    return u[1:-1].strip() if u[:1] + u[-1:] in ("[]", "()") else u


def read_columns(
    path: Path,
    wanted: list[str],
    time: str,
    *,
    units_row: bool | None = None,
    time_format: str | None = None,
    delimiter: str | None = None,
    decimal: str | None = None,
) -> CsvColumns:
    """Only the `wanted` columns and the time column of a CSV log, in the file's own
    delimiter and decimal sign (read_table, decimal_sign). A cell in MISSING is NaN (that
    column has no sample on that row); any other cell that is not a number is refused
    with its line and column. Columns are found by name or by the whole header cell; a
    row of units under the header (asammdf's export, spreadsheets') gives units, found
    as such unless `units_row` says."""
    rows, _ = read_table(path, delimiter)
    head_line, head = rows[0]
    cells = [c.strip() for c in head]
    parsed = [header_cell(c) for c in cells]
    body = rows[1:]
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
    read = sorted({jt, *cols.values()})
    numbers = ((line, cells[j], row[j]) for line, row in body for j in read if j < len(row))
    dec = decimal_sign(path, numbers, decimal)
    if units_row is None:
        units_row = bool(body) and _is_units_row(body[0][1], jt, dec)
    if units_row:
        if not body:
            raise LogError(f"{path}: no units row under the header (line {head_line + 1})")
        parsed = [
            (n, _unbracketed(u) or pu) for (n, pu), u in zip(parsed, body[0][1], strict=False)
        ]
        body = body[1:]
    n = len(body)
    t = np.full(n, np.nan)
    values = {name: np.full(n, np.nan) for name in cols}
    lines = np.array([line for line, _ in body], dtype=np.int64)
    text_time = of_day = False
    for i, (line, row) in enumerate(body):
        if _blank(row):
            continue
        if len(row) < len(cells):
            raise LogError(
                f"{path}: line {line} has {len(row)} fields, the header {len(cells)}"
                + (" (the file looks cut short)" if i == n - 1 else "")
            )
        if any(c.strip() for c in row[len(cells) :]):
            raise LogError(
                f"{path}: line {line} has {len(row)} fields, the header {len(cells)}: a value "
                "with an unquoted comma (a decimal comma?) shifts every column after it; "
                "quote such values, or export with a decimal point"
            )
        cell = row[jt].strip()
        if cell.lower() not in MISSING:
            try:
                t[i] = number(cell, dec)
            except ValueError:
                try:
                    t[i], of_day = _stamp(cell, time_format)
                    text_time = True
                except ValueError:
                    how = f"`{time_format}`" if time_format else "ISO 8601"
                    units_hint = (
                        " (if this row holds units, set [log] units_row = true)" if i == 0 else ""
                    )
                    raise LogError(
                        f"{path}: line {line}, column {time}: {cell!r} is neither a number nor "
                        f"a time stamp in {how}; set [log] time_format (strptime codes)"
                        + units_hint
                    ) from None
        for name, j in cols.items():
            cell = row[j].strip()
            if cell.lower() in MISSING:
                continue
            try:
                values[name][i] = number(cell, dec)
            except ValueError as exc:
                raise LogError(
                    f"{path}: line {line}, column {name}: {exc} (missing values may be "
                    f"{', '.join(repr(m) for m in sorted(MISSING))})"
                ) from None
    if of_day:
        t = _past_midnight(t)
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
