"""Raw CAN logs decoded with a DBC: ASAM MF4 bus logging, BLF, ASC and candump -L.

python-can reads the frames (its reader is picked by the file's suffix), cantools
decodes the messages the scenario names; signals are named `MESSAGE.SIGNAL` and carry
the DBC's scaling and unit. Each signal keeps its own time stamps: those of the frames
that carried it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vehil.csvlog import LogError

# Formats read as raw frames (an MDF4 file with a DBC is read as bus logging).
CAN_FORMATS = ("blf", "asc", "candump")


def read_can(
    path: Path, fmt: str, dbc: Path, signals: list[str]
) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
    """Each `MESSAGE.SIGNAL` as (time stamps in s, values, unit)."""
    import can
    import cantools

    try:
        db: Any = cantools.database.load_file(str(dbc))
    except FileNotFoundError:
        raise LogError(
            f"{dbc}: no such DBC file (set [log] dbc, relative to the scenario)"
        ) from None
    except Exception as exc:  # cantools raises parser errors of several types
        raise LogError(f"{dbc}: not a readable DBC: {exc}") from None
    wanted: dict[int, list[tuple[str, str]]] = {}
    units: dict[str, str] = {}
    for full in signals:
        msg_name, _, sig_name = full.partition(".")
        try:
            msg = db.get_message_by_name(msg_name)
            sig = msg.get_signal_by_name(sig_name)
        except KeyError:
            some = ", ".join(f"{m.name}.{s.name}" for m in db.messages[:6] for s in m.signals[:3])
            raise LogError(
                f"{path}: {full!r} is not a MESSAGE.SIGNAL of {dbc.name}; some: {some}"
            ) from None
        wanted.setdefault(msg.frame_id, []).append((full, sig_name))
        units[full] = sig.unit or ""
    stamps: dict[str, list[float]] = {s: [] for s in signals}
    values: dict[str, list[float]] = {s: [] for s in signals}
    reader_cls = {
        "mdf4": can.MF4Reader,
        "blf": can.BLFReader,
        "asc": can.ASCReader,
        "candump": can.CanutilsLogReader,
    }[fmt]
    frames = 0
    try:
        reader = reader_cls(str(path))
        for frame in reader:
            frames += 1
            todo = wanted.get(frame.arbitration_id)
            if todo is None or frame.is_error_frame or frame.is_remote_frame:
                continue
            try:
                decoded: Any = db.decode_message(
                    frame.arbitration_id, bytes(frame.data), decode_choices=False
                )
            except Exception as exc:  # a frame shorter than its DBC message, a bad mux
                raise LogError(
                    f"{path}: frame {frames} (t = {frame.timestamp:.6f} s, id "
                    f"0x{frame.arbitration_id:X}) does not decode with {dbc.name}: {exc}"
                ) from None
            for full, sig_name in todo:
                if sig_name in decoded:  # a multiplexed signal is in some frames only
                    stamps[full].append(frame.timestamp)
                    values[full].append(float(decoded[sig_name]))
    except LogError:
        raise
    except Exception as exc:  # python-can raises many types for a bad file
        raise LogError(f"{path}: not a readable {fmt} CAN log (frame {frames}): {exc}") from None
    held, whole = path.stat().st_size, getattr(reader, "file_size", 0)  # BLF's header
    if whole > held:  # python-can's reader stops where the bytes end, and says nothing
        raise LogError(
            f"{path}: the file is cut short: its header says {whole:,} B, it holds {held:,} "
            f"({frames:,} frames read); a run on it would check part of the drive as the whole"
        )
    out = {}
    for s in signals:
        if not stamps[s]:
            raise LogError(
                f"{path}: no frame of {s.partition('.')[0]} in {frames} frames; check the DBC "
                "and the bus the log recorded"
            )
        out[s] = (np.asarray(stamps[s]), np.asarray(values[s]), units[s])
    return out
