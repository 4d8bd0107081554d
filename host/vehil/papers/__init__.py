"""One module per seed paper: its scenarios' checks and its `vehil reproduce` table.

A paper module defines KEY, TITLE and `reproduce(console, board=None) -> int`
(0 when every check of its issue holds).
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType


def papers() -> dict[str, ModuleType]:
    found = {}
    for mod in pkgutil.iter_modules(__path__):
        module = importlib.import_module(f"{__name__}.{mod.name}")
        if hasattr(module, "KEY") and hasattr(module, "reproduce"):
            found[module.KEY] = module
    return found
