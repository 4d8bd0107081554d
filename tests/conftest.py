"""Shared fixtures: build products once per session, boards per module."""

from __future__ import annotations

import os

import pytest

from vehil.build import build


@pytest.fixture(scope="session", autouse=True)
def _runs_in_a_temporary_folder(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Runs that name no folder go to $VEHIL_RUNS: the checkout gets no runs/ from tests."""
    os.environ["VEHIL_RUNS"] = str(tmp_path_factory.mktemp("runs"))


@pytest.fixture(scope="session")
def built() -> dict:
    """Builds the firmware, the simavr bridge and the native library (incrementally)."""
    return build()


@pytest.fixture(scope="session")
def native_lib(built):  # noqa: ANN001, ANN201
    from vehil.transports.protocol_native import load_library

    return load_library(built["native"])
