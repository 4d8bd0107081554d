"""A name -> item registry filled by the modules of a package, imported on first use."""

from __future__ import annotations

import importlib
import pkgutil
from typing import Generic, TypeVar

T = TypeVar("T")


class Registry(Generic[T]):
    def __init__(self, package: str, what: str):
        self.package = package
        self.what = what
        self._items: dict[str, T] = {}
        self._loaded = False

    def add(self, name: str, item: T) -> T:
        if name in self._items:
            raise ValueError(f"{self.what} {name!r} registered twice")
        self._items[name] = item
        return item

    def all(self) -> dict[str, T]:
        if not self._loaded:
            self._loaded = True
            path = importlib.import_module(self.package).__path__
            for mod in pkgutil.iter_modules(path):
                if mod.name != "base" and not mod.name.startswith("_"):
                    importlib.import_module(f"{self.package}.{mod.name}")
        return dict(self._items)

    def get(self, name: str) -> T:
        known = self.all()
        if name not in known:
            raise KeyError(f"no {self.what} {name!r}; known: {', '.join(sorted(known))}")
        return known[name]
