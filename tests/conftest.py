"""Shared fixtures: build products once per session, boards per module.

Under pytest-xdist (`make test` runs `-n auto`) each worker is its own session: its own
temporary folder and runs folder, and its own boards (each board process picks its own pty
or loopback port). The build is shared, so workers take it in turn under a file lock; after
`make build` it finds everything up to date.
"""

from __future__ import annotations

import fcntl
import json
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from vehil.build import build
from vehil.paths import BUILD_DIR

# Property tests judge what the code returns, not how fast a loaded host ran it: no
# per-example deadline (Hypothesis's 200 ms fails an example a starved worker ran slowly,
# or calls it flaky when its rerun is quick) and no health check on how fast examples are made.
settings.register_profile("vehil", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("vehil")

# pytest-xdist's workers start with COLUMNS=80 in their environment, which would fold
# vehil's output at 80 columns where a CI log gets it at full width (vehil.terminal).
os.environ.pop("COLUMNS", None)


# Modules whose tests share a costly module fixture: under pytest-xdist each runs whole on
# one worker, which sets the fixture up once (xdist's own xdist_group mark cannot do it under
# pytest 9: it renames the tests through a node attribute pytest no longer reads).
ONE_WORKER_MODULES = {
    "tests/hil/test_labgrid_hil.py",  # the lab: a coordinator, an exporter, two boards
    "tests/hil/test_vendored_hil.py",  # the fixture project's build
    "tests/hil/test_kernels_hil.py",  # the kernels' fixture project's build
    "tests/hil/test_flash_hil.py",  # the board flashed once
    "tests/hil/test_boot_baud_hil.py",  # the 115200 image built once, not by two workers at once
    "tests/native/test_campaign_native.py",  # a campaign on a local Dask cluster
    "tests/native/test_sweep_native.py",  # a sweep of six runs
    "tests/native/test_cli_native.py",  # a 10,000-sample run
}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Tests marked `long` run first, each kind keeping its order (the sort is stable): the
    workers take tests one at a time (pytest_xdist_make_scheduler), so the longest start at
    once and a run ends on short tests on every worker, not on one long test while the
    other workers wait."""
    items.sort(key=lambda item: item.get_closest_marker("long") is None)


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist's, absent under -p no:xdist
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object:
    """Each worker takes the next test when it is done with its own (a module of
    ONE_WORKER_MODULES: the next whole module), in the order above."""
    from xdist.scheduler import LoadScopeScheduling

    config.option.loadscopereorder = False  # the order is the collection's: long ones first

    class OneAtATime(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return module if module in ONE_WORKER_MODULES else nodeid

    return OneAtATime(config, log)


@pytest.fixture(scope="session", autouse=True)
def _runs_in_a_temporary_folder(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Runs that name no folder go to $VEHIL_RUNS: the checkout gets no runs/ from tests."""
    os.environ["VEHIL_RUNS"] = str(tmp_path_factory.mktemp("runs"))


@pytest.fixture(scope="session")
def built() -> dict[str, Path]:
    """Builds the firmware, the simavr bridge and the native library (incrementally), once
    per test run: under pytest-xdist the first worker builds, under a file lock (two builds
    writing the same objects would corrupt them), and the others take what it built. A
    second build meanwhile would cost each worker a build's start-up for nothing, and any
    image it relinked would be rewritten under the boards of the workers already running."""
    lock = BUILD_DIR / ".build.lock"
    lock.parent.mkdir(exist_ok=True)
    run = os.environ.get("PYTEST_XDIST_TESTRUNUID")  # the same in every worker of one run
    done = BUILD_DIR / ".built-in-test-run.json"
    with lock.open("w") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        if run and done.exists():
            before = json.loads(done.read_text())
            if before["run"] == run:
                return {part: Path(path) for part, path in before["products"].items()}
        products = build()
        if run:
            saved = {part: str(path) for part, path in products.items()}
            done.write_text(json.dumps({"run": run, "products": saved}))
        return products


@pytest.fixture(scope="session")
def native_lib(built):  # noqa: ANN001, ANN201
    from vehil.transports.protocol_native import load_library

    return load_library(built["native"])


@pytest.fixture
def torque_log(tmp_path):  # noqa: ANN001, ANN201
    """An OBD app's export (Torque's layout): text time stamps at 1 Hz with jitter, `-` and
    empty cells, km/h and g headers; speed 10 m/s + 0.1 m/s per s, acceleration 0.1 m/s²."""
    head = (
        "GPS Time, Device Time, Longitude, Speed (OBD)(km/h), Acceleration Sensor(X axis)(g),"
        " Engine RPM(rpm)\n"
    )
    rows = []
    for k in range(200):
        ms = (37 * k) % 100  # stamps jitter by up to 0.1 s
        stamp = f"25-Nov-2026 10:{k // 60:02d}:{k % 60:02d}.{ms:03d}"
        speed = "-" if k % 17 == 5 else f"{36 + 0.36 * (k + ms / 1000):.4f}"
        acc = "" if k % 23 == 7 else f"{0.1 / 9.80665:.6f}"
        rows.append(f"-, {stamp}, -, {speed}, {acc}, -")
    path = tmp_path / "torque.csv"
    path.write_text(head + "\n".join(rows) + "\n")
    return path


DBC = """VERSION ""
BU_: ECU
BO_ 291 WHEEL_SPEEDS: 4 ECU
 SG_ WHEEL_SPEED_FL : 0|16@1+ (0.01,0) [0|655.35] "km/h" ECU
 SG_ WHEEL_SPEED_FR : 16|16@1+ (0.01,0) [0|655.35] "km/h" ECU
BO_ 292 ACCEL: 2 ECU
 SG_ ACCEL_X : 0|16@1- (0.001,0) [-32|32] "m/s^2" ECU
"""


@pytest.fixture
def can_log(tmp_path):  # noqa: ANN001, ANN201
    """A writer of 2 s of raw CAN (python-can picks the format by suffix) and its DBC:
    wheel speeds in km/h at 100 Hz (10 m/s + 0.5 m/s²), acceleration at 50 Hz."""
    return lambda suffix: _can_log(tmp_path, suffix)


def _can_log(tmp_path: Path, suffix: str) -> tuple[Path, Path]:
    import can
    import cantools

    dbc = tmp_path / "car.dbc"
    dbc.write_text(DBC)
    db = cantools.database.load_file(str(dbc))
    path = tmp_path / f"drive{suffix}"
    with can.Logger(str(path)) as writer:
        for k in range(200):
            t = 1000.0 + k * 0.01
            kmh = 36 + 3.6 * 0.5 * k * 0.01  # 10 m/s + 0.5 m/s²
            data = db.encode_message("WHEEL_SPEEDS", {"WHEEL_SPEED_FL": kmh, "WHEEL_SPEED_FR": kmh})
            writer(can.Message(timestamp=t, arbitration_id=291, data=data, is_extended_id=False))
            if k % 2 == 0:
                data = db.encode_message("ACCEL", {"ACCEL_X": 0.5})
                writer(
                    can.Message(
                        timestamp=t + 0.003, arbitration_id=292, data=data, is_extended_id=False
                    )
                )
    return path, dbc


@pytest.fixture(scope="session")
def write_short_sines():  # noqa: ANN201
    """Writes three 1-s sines into a folder: sine-a, sine-b (another seed) and sine-noisy,
    whose truth bound (0.01) its noise (RMS 0.05) fails on every run."""
    from vehil.paths import DATA_ROOT

    def write(folder: Path) -> None:
        sine = (DATA_ROOT / "scenarios" / "synthetic" / "sine.toml").read_text()
        short = sine.replace("duration = 20.0", "duration = 1.0")
        (folder / "sine-a.toml").write_text(short)
        (folder / "sine-b.toml").write_text(short.replace("seed = 1", "seed = 2"))
        noisy = short.replace("truth_rms = 0.06", "truth_rms = 0.01")
        (folder / "sine-noisy.toml").write_text(noisy)

    return write
