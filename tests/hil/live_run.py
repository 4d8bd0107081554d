"""A real-time `vehil run` under way: its first batch of samples recorded, so a test that
cuts it short cuts a run that has samples, however long this host took to start it
(the frames are made before the clock starts)."""

import subprocess
import time
from pathlib import Path

from vehil import record


def wait_for_samples(proc: subprocess.Popen, out: Path, within_s: float = 90) -> None:
    """Return once `out/run.arrow` holds samples; fail if the run ends or never gets there."""
    path = out / "run.arrow"
    deadline = time.monotonic() + within_s
    while True:
        assert proc.poll() is None, "the run ended before it recorded a sample"
        assert time.monotonic() < deadline, f"no sample recorded within {within_s:.0f} s"
        if path.exists():
            try:
                if len(record.read(path)) > 0:
                    return
            except record.RecordingError:
                pass  # its header is not written yet
        time.sleep(0.1)
