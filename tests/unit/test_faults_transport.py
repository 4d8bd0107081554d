"""The fault-injecting port: specs are checked, faults are seeded and counted."""

import pytest
import serial

from vehil.protocol.schema import SCHEMA
from vehil.transports.protocol_faults import parse_spec, wrap_url


def test_a_spec_becomes_a_url_and_bad_specs_name_the_problem() -> None:
    assert wrap_url("native://", "drop=1e-3,seed=7") == "faults://native://?drop=0.001&seed=7.0"
    with pytest.raises(ValueError, match="unknown fault 'lose'"):
        parse_spec("lose=0.1")
    with pytest.raises(ValueError, match="not a probability"):
        parse_spec("flip=2")
    with pytest.raises(ValueError, match="needs a number"):
        parse_spec("dup=often")


def test_faults_are_seeded_counted_and_only_while_armed() -> None:
    def broken(seed: int) -> tuple[bytes, dict]:
        port = serial.serial_for_url(
            wrap_url("loop://", f"flip=0.05,drop=0.05,seed={seed}"), timeout=0.1
        )
        port.write(bytes(range(200)))
        clean = port.read(200)
        port.arm()
        port.write(bytes(range(200)))
        out = port.read(400)
        counts = dict(port.counts)
        port.disarm()
        port.write(bytes(range(200)))
        assert port.read(200) == bytes(range(200))
        assert dict(port.counts) == counts
        port.close()
        assert clean == bytes(range(200))
        return out, counts

    a, counts = broken(1)
    assert a == broken(1)[0] != broken(2)[0]
    assert counts["flip to board"] > 0 and counts["drop to board"] > 0
    assert len(a) == 200 - counts["drop to board"] - counts.get("drop from board", 0)


def test_reboot_after_slips_one_reboot_request_in_after_that_many_writes() -> None:
    from vehil.protocol import frame

    port = serial.serial_for_url(wrap_url("loop://", "reboot_after=2"), timeout=0.1)
    port.arm()
    for payload in (b"a", b"b", b"c"):
        port.write(payload)
    data = port.read(100)
    port.close()
    assert data[:2] == b"ab" and data.endswith(b"c")
    (reboot,) = frame.StreamDecoder().feed(data[2:-1])
    assert (reboot.name, reboot.fields()) == ("RESET", {"what": SCHEMA.reset_what["REBOOT"]})
    assert port.counts["reboot"] == 1
