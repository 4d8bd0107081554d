"""The plant registry: each module in this package registers its PlantSpec(s)."""

from __future__ import annotations

import importlib
import pkgutil

from vehil.plants.base import PlantSpec, Trace

_REGISTRY: dict[str, PlantSpec] = {}


def register(spec: PlantSpec) -> PlantSpec:
    if spec.name in _REGISTRY:
        raise ValueError(f"plant {spec.name!r} registered twice")
    _REGISTRY[spec.name] = spec
    return spec


def plants() -> dict[str, PlantSpec]:
    if not _REGISTRY:
        for mod in pkgutil.iter_modules(__path__):
            if mod.name != "base" and not mod.name.startswith("_"):
                importlib.import_module(f"{__name__}.{mod.name}")
    return dict(_REGISTRY)


def get(name: str) -> PlantSpec:
    known = plants()
    if name not in known:
        raise KeyError(f"no plant {name!r}; known: {', '.join(sorted(known))}")
    return known[name]


__all__ = ["PlantSpec", "Trace", "get", "plants", "register"]
