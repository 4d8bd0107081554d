"""A name -> item registry filled on first use by the modules of a package, then by
packaged plug-ins (the entry point group `vehil.<what>s`: each entry names a module that
registers its items, or an item), then by the current project's modules (vehil.toml)."""

from __future__ import annotations

import importlib
import pkgutil
from importlib.metadata import entry_points
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
            self._load_plugins()
        return dict(self._items)

    def _load_plugins(self) -> None:
        from vehil import project

        for ep in entry_points(group=f"vehil.{self.what}s"):
            try:
                ep.load()  # a module registers its items as it is imported
            except Exception as exc:
                raise project.ProjectError(
                    f"entry point {ep.name} = {ep.value} (group vehil.{self.what}s): {exc!r}"
                ) from exc
        here = project.current()
        for path in here.modules(self.what) if here else ():
            project.import_module(path, self.what)

    def get(self, name: str) -> T:
        known = self.all()
        if name not in known:
            raise KeyError(f"no {self.what} {name!r}; known: {', '.join(sorted(known))}")
        return known[name]
