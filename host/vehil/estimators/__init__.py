"""The estimator registry. Each module in this package registers its EstimatorSpec(s);
nothing outside names a particular estimator."""

from __future__ import annotations

import importlib
import pkgutil

from vehil.estimators.base import EstimatorSpec, Param, Reference, Signal

_REGISTRY: dict[str, EstimatorSpec] = {}


def register(spec: EstimatorSpec) -> EstimatorSpec:
    if spec.name in _REGISTRY:
        raise ValueError(f"estimator {spec.name!r} registered twice")
    if any(s.c_id == spec.c_id for s in _REGISTRY.values()):
        raise ValueError(f"estimator {spec.name!r}: C id {spec.c_id} is taken")
    _REGISTRY[spec.name] = spec
    return spec


def _discover() -> None:
    for mod in pkgutil.iter_modules(__path__):
        if mod.name != "base" and not mod.name.startswith("_"):
            importlib.import_module(f"{__name__}.{mod.name}")


def estimators() -> dict[str, EstimatorSpec]:
    if not _REGISTRY:
        _discover()
    return dict(_REGISTRY)


def get(name: str) -> EstimatorSpec:
    known = estimators()
    if name not in known:
        raise KeyError(f"no estimator {name!r}; known: {', '.join(sorted(known))}")
    return known[name]


__all__ = ["EstimatorSpec", "Param", "Reference", "Signal", "estimators", "get", "register"]
