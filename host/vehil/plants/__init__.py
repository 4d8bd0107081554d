"""The plant registry: each module in this package registers its PlantSpec(s)."""

from __future__ import annotations

from vehil.plants.base import PlantSpec, Trace
from vehil.registry import Registry

_REGISTRY: Registry[PlantSpec] = Registry(__name__, "plant")


def register(spec: PlantSpec) -> PlantSpec:
    return _REGISTRY.add(spec.name, spec)


def plants() -> dict[str, PlantSpec]:
    return _REGISTRY.all()


def get(name: str) -> PlantSpec:
    return _REGISTRY.get(name)


__all__ = ["PlantSpec", "Trace", "get", "plants", "register"]
