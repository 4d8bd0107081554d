"""The estimator registry. Each module in this package registers its EstimatorSpec(s);
nothing outside names a particular estimator."""

from __future__ import annotations

from vehil.estimators.base import EstimatorSpec, Param, Reference, Signal
from vehil.registry import Registry

_REGISTRY: Registry[EstimatorSpec] = Registry(__name__, "estimator")


def register(spec: EstimatorSpec) -> EstimatorSpec:
    taken = [s.name for s in _REGISTRY._items.values() if s.c_id == spec.c_id]
    if taken:
        raise ValueError(f"estimator {spec.name!r}: C id {spec.c_id} is taken by {taken[0]}")
    return _REGISTRY.add(spec.name, spec)


def estimators() -> dict[str, EstimatorSpec]:
    return _REGISTRY.all()


def get(name: str) -> EstimatorSpec:
    return _REGISTRY.get(name)


__all__ = ["EstimatorSpec", "Param", "Reference", "Signal", "estimators", "get", "register"]
