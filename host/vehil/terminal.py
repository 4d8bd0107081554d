"""Consoles for vehil's output: on a terminal, rich's own layout; anywhere else (a CI
log, `| tee`, a file) tables at their full width instead of cut at rich's default 80
columns, since nobody will resize that window."""

from __future__ import annotations

import os
from typing import Any

from rich.console import Console

OFF_TERMINAL_WIDTH = 1000  # wide enough for any table vehil prints; rich fits a table to it


def make_console(**options: Any) -> Console:
    console = Console(**options)
    if not console.is_terminal and "COLUMNS" not in os.environ and "width" not in options:
        console.width = OFF_TERMINAL_WIDTH
    return console
