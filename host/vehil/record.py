"""Recordings: one self-describing file per run, written as the run goes.

The format is an Arrow IPC stream (`.arrow`; pyarrow, pandas, polars and DuckDB
read it). The schema's metadata carries everything needed to understand and
redo the run: scenario, estimator signals with units and Q formats, board INFO,
firmware build id, host versions. Samples follow in batches, each written as
soon as it is full, so a crash loses at most the last batch; a final empty
batch carries how the run ended. A stream cut short reads back up to its last
whole batch, and says so.

Columns: k, t, the inputs as sent (`in.<name>`), `truth.<name>`, `ref.<name>`
(float64 reference), `board.<name>` (as decoded from the board), `status`
(RESULT flags), `cycles` (board, per step), `rtt_s` (host round trip), `late`
(real-time runs: the result came after the next sample was due).
"""

from __future__ import annotations

import contextlib
import json
import platform
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.ipc as ipc

from vehil.errors import VehilError

FORMAT = "vehil-run/1"
BATCH_ROWS = 1000


_IPC_START = b"\xff\xff\xff\xff"  # an Arrow IPC stream's first message marker


class RecordingError(VehilError):
    """A recording cannot be read: the message says where it broke."""


def host_versions() -> dict[str, str]:
    versions = {"python": sys.version.split()[0], "platform": platform.platform()}
    for pkg in ("vehil", "numpy", "scipy", "pyarrow", "pyserial", "platformio"):
        with contextlib.suppress(metadata.PackageNotFoundError):
            versions[pkg] = metadata.version(pkg)
    return versions


def columns(
    inputs: list[str], outputs: list[str], with_truth: list[str], plant: Sequence[str] = ()
) -> pa.Schema:
    """`plant`: a closed loop's measured signals, kept as `plant.<name>` (its trajectory
    is made with the board's outputs: the recording is its only record)."""
    f64 = pa.float64()
    fields = [pa.field("k", pa.int32()), pa.field("t", f64)]
    fields += [pa.field(f"in.{n}", f64) for n in inputs]
    fields += [pa.field(f"truth.{n}", f64) for n in with_truth]
    fields += [pa.field(f"ref.{n}", f64) for n in outputs]
    fields += [pa.field(f"board.{n}", f64) for n in outputs]
    fields += [pa.field(f"plant.{n}", f64) for n in plant]
    fields += [
        pa.field("status", pa.uint8()),
        pa.field("cycles", pa.uint32()),
        pa.field("rtt_s", f64),
        pa.field("late", pa.bool_()),
    ]
    return pa.schema(fields)


def load_conversions() -> None:
    """Loads what pyarrow needs to make arrays from Python values: its first such array
    imports pandas (0.15-0.5 s, more on a loaded host), which a run does before it starts,
    not in its first batch, in the middle of a real-time loop (141 ms at sample 999)."""
    pa.array([0.0])


class Recorder:
    """Appends rows; flushes a batch every BATCH_ROWS rows; `close(end)` seals the file."""

    def __init__(
        self,
        path: Path,
        schema: pa.Schema,
        header: dict[str, Any],
        on_batch: Callable[[dict[str, np.ndarray]], None] | None = None,
    ):
        self.path = path
        self.on_batch = on_batch  # sees each batch's columns as it is written
        path.parent.mkdir(parents=True, exist_ok=True)
        header = {"format": FORMAT, "host": host_versions(), **header}
        self.schema = schema.with_metadata({"vehil": json.dumps(header, default=_jsonable)})
        self._sink = pa.OSFile(str(path), "wb")
        self._writer = ipc.new_stream(
            self._sink, self.schema, options=ipc.IpcWriteOptions(compression="zstd")
        )
        self._rows: dict[str, list[Any]] = {name: [] for name in self.schema.names}
        self.rows_written = 0

    def append(self, row: dict[str, Any]) -> None:
        for name, values in self._rows.items():
            values.append(row.get(name))
        if len(self._rows["k"]) >= BATCH_ROWS:
            self.flush()

    def flush(self) -> None:
        n = len(self._rows["k"])
        if n:
            batch = pa.record_batch(self._rows, schema=self.schema)
            self._writer.write_batch(batch)
            self.rows_written += n
            if self.on_batch is not None:
                self.on_batch(_columns(batch))
            self._sink.flush()
            for values in self._rows.values():
                values.clear()

    def close(self, end: dict[str, Any]) -> None:
        self.flush()
        end = {**end, "samples": self.rows_written}
        empty = pa.record_batch({n: [] for n in self.schema.names}, schema=self.schema)
        self._writer.write_batch(empty, custom_metadata={"end": json.dumps(end, default=_jsonable)})
        self._writer.close()
        self._sink.close()


def _jsonable(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path | bytes):
        return str(x)
    return repr(x)


@dataclass
class Recording:
    """A run read back: its header, its columns, how it ended (or where it was cut)."""

    path: Path
    header: dict[str, Any]
    data: dict[str, np.ndarray]
    end: dict[str, Any] | None
    truncated: str | None = None  # why reading stopped early, if it did
    units: dict[str, str] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.data["k"])

    @property
    def outputs(self) -> list[str]:
        return [s["name"] for s in self.header["estimator"]["outputs"]]

    @property
    def inputs(self) -> list[str]:
        return [s["name"] for s in self.header["estimator"]["inputs"]]

    @property
    def cut_short(self) -> str | None:
        """Why this recording holds less than its whole drive, or None if it holds it all."""
        if self.truncated:
            return self.truncated
        if self.end is not None and self.end.get("ended") != "completed":
            return f"its run ended {self.end.get('ended')} after {len(self):,} samples"
        expected = self.header.get("expected_samples")
        if expected is not None and len(self) < expected:
            return f"it holds {len(self):,} of its run's {expected:,} samples"
        return None


def _columns(batch: pa.RecordBatch) -> dict[str, np.ndarray]:
    return {name: batch.column(name).to_numpy(zero_copy_only=False) for name in batch.schema.names}


class Reader:
    """A recording's header, then its batches one at a time: a run of any length is read
    in the memory of one batch. After the batches, `end` and `truncated` say how it ended."""

    def __init__(self, path: Path):
        self.path = Path(path)
        if not self.path.is_file():
            raise RecordingError(f"{path}: no such recording (give a run.arrow or its folder)")
        try:
            self._reader = ipc.open_stream(pa.OSFile(str(path), "rb"))
        except (OSError, pa.ArrowInvalid) as exc:
            with open(path, "rb") as f:
                cut = f.read(4) == _IPC_START  # an Arrow stream that ends in its header
            what = "cut short in its header, before any sample" if cut else "not a vehil recording"
            raise RecordingError(f"{path}: {what} ({exc})") from None
        meta = self._reader.schema.metadata or {}
        if b"vehil" not in meta:
            raise RecordingError(f"{path}: an Arrow stream, but without vehil's header")
        self.header: dict[str, Any] = json.loads(meta[b"vehil"])
        if self.header.get("format") != FORMAT:
            raise RecordingError(
                f"{path}: format {self.header.get('format')!r}, this vehil reads {FORMAT}"
            )
        self.schema = self._reader.schema
        self.units = {
            s["name"]: s["unit"]
            for part in ("inputs", "outputs")
            for s in self.header["estimator"][part]
        }
        self.end: dict[str, Any] | None = None
        self.truncated: str | None = None
        self.rows = 0

    def batches(self) -> Iterator[pa.RecordBatch]:
        while True:
            try:
                batch, custom = self._reader.read_next_batch_with_custom_metadata()
            except StopIteration:
                break
            except (pa.ArrowInvalid, OSError) as exc:
                self.truncated = f"the file is cut short after {self.rows} samples ({exc})"
                break
            if custom and b"end" in custom:
                self.end = json.loads(custom[b"end"])
            self.rows += len(batch)
            yield batch
        if self.end is None and self.truncated is None:
            self.truncated = "the run did not finish writing (no end record)"

    def columns(self) -> Iterator[dict[str, np.ndarray]]:
        """Each non-empty batch's columns as numpy arrays."""
        for batch in self.batches():
            if len(batch):
                yield _columns(batch)


def read(path: Path, every: int = 1) -> Recording:
    """The whole recording; `every` > 1 keeps every that many samples (for a plot)."""
    reader = Reader(path)
    kept: list[pa.RecordBatch] = []
    for batch in reader.batches():
        if every > 1:
            first = -(reader.rows - len(batch)) % every
            batch = batch.take(pa.array(np.arange(first, len(batch), every)))
        kept.append(batch)
    table = pa.Table.from_batches(kept, schema=reader.schema)
    data = {name: table.column(name).to_numpy() for name in table.column_names}
    return Recording(Path(path), reader.header, data, reader.end, reader.truncated, reader.units)
