"""Consoles for vehil's output: on a terminal, rich's own layout; anywhere else (a CI
log, `| tee`, a file) tables at their full width instead of cut at rich's default 80
columns, since nobody will resize that window. With `tables` set to a list, a console
keeps the tables it is given as data instead of drawing them (`--json`)."""

from __future__ import annotations

import os
from typing import Any

from rich.console import Console
from rich.table import Table
from rich.text import Text

OFF_TERMINAL_WIDTH = 1000  # wide enough for any table vehil prints; rich fits a table to it


class TableConsole(Console):
    tables: list[dict[str, Any]] | None = None

    def print(self, *objects: Any, **options: Any) -> None:
        if self.tables is not None:
            self.tables += [table_data(o) for o in objects if isinstance(o, Table)]
            objects = tuple(o for o in objects if not isinstance(o, Table))
            if not objects:
                return
        super().print(*objects, **options)


def _plain(cell: Any) -> str:
    return Text.from_markup(cell).plain if isinstance(cell, str) else str(cell)


def table_data(table: Table) -> dict[str, Any]:
    """A table as its title, caption and rows of {column header: cell text}."""
    headers = [_plain(c.header).replace("\n", " ") for c in table.columns]
    rows = zip(*(c.cells for c in table.columns), strict=True)
    return {
        "title": _plain(table.title or ""),
        "caption": _plain(table.caption or ""),
        "rows": [dict(zip(headers, map(_plain, row), strict=True)) for row in rows],
    }


def make_console(**options: Any) -> TableConsole:
    console = TableConsole(**options)
    if not console.is_terminal and "COLUMNS" not in os.environ and "width" not in options:
        console.width = OFF_TERMINAL_WIDTH
    return console
