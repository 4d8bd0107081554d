"""The firmware's message core, run in-process through the native board.

The same C runs on the ATmega2560; these pin its replies to each request,
good and bad, without a simulator in the way.
"""

import struct

import pytest

from vehil.boards import BoardOptions, open_board
from vehil.errors import BoardError, LinkError
from vehil.protocol import frame
from vehil.protocol.schema import SCHEMA


@pytest.fixture
def link(built):  # noqa: ANN001, ANN201
    with open_board("native", BoardOptions(timeout_s=0.2)) as link:
        yield link


def test_info_describes_the_board_and_its_estimators(link) -> None:
    info = link.info
    assert info.fields["protocol"] == SCHEMA.protocol_version
    assert info.fields["max_body"] == SCHEMA.max_body
    assert info.reset_cause == "POWER_ON"
    assert info.estimators[0].name == "passthrough"


def test_the_board_has_every_estimator_the_host_knows_with_the_same_shape(link) -> None:
    from vehil import estimators

    on_board = {e.name: e for e in link.info.estimators}
    for name, spec in estimators.estimators().items():
        assert name in on_board, f"{name} has a host spec but is not built into the firmware"
        e = on_board[name]
        assert e.id == spec.c_id
        if name != "passthrough":  # it takes any length
            shape = (e.n_inputs, e.n_outputs, e.n_params)
            assert shape == (len(spec.inputs), len(spec.outputs), len(spec.params)), name
        assert set(spec.modes) <= set(e.modes)


def test_hello_with_another_protocol_version_is_refused_naming_the_boards(link) -> None:
    with pytest.raises(BoardError, match=f"VERSION.*v{SCHEMA.protocol_version}"):
        link.request("HELLO", protocol=SCHEMA.protocol_version + 1)


def test_config_with_an_unknown_estimator_id_is_an_error(link) -> None:
    with pytest.raises(BoardError, match="UNKNOWN_ESTIMATOR.*id 200") as exc:
        link.request("CONFIG", estimator=200, mode=0, offset=0, params=b"")
    assert exc.value.code == "UNKNOWN_ESTIMATOR" and exc.value.detail == 200


def test_config_with_an_unknown_mode_is_an_error(link) -> None:
    with pytest.raises(BoardError, match="UNSUPPORTED_MODE"):
        link.request("CONFIG", estimator=0, mode=9, offset=0, params=b"")


def test_sample_before_config_is_refused(link) -> None:
    with pytest.raises(BoardError, match="NOT_CONFIGURED"):
        link.request("SAMPLE", inputs=b"\x01\x02\x03\x04")


def test_passthrough_returns_its_inputs_in_order(link) -> None:
    link.configure("passthrough", "F32")
    inputs = [struct.pack("<2f", i, -i) for i in range(500)]
    replies = list(link.pipeline((("SAMPLE", {"inputs": x}) for x in inputs), window=8))
    assert [r.fields()["outputs"] for r in replies] == inputs
    assert all(r.fields()["status"] == 0 for r in replies)


def test_passthrough_refuses_a_sample_whose_echo_would_not_fit(link) -> None:
    link.configure("passthrough", "F32")
    with pytest.raises(BoardError, match="BAD_LENGTH.*125 bytes"):  # index + 123
        link.request("SAMPLE", inputs=bytes(124))


def _rls(link) -> list[bytes]:  # noqa: ANN001
    """Three RLS samples: a stateful estimator, so a second step would show."""
    from vehil.estimators import stlqf

    spec = stlqf.RLS
    link.configure("rls", "F32", spec.encode_params(spec.param_values({}), "F32"))
    return [spec.encode_inputs([20.0 + k, 0.5, 1500.0 + 100 * k], "F32") for k in range(3)]


def test_a_repeated_sample_is_answered_from_the_cache_without_stepping_again(link) -> None:
    inputs = _rls(link)
    first = [link.request("SAMPLE", inputs=x).fields() for x in inputs[:2]]
    again = link.request("SAMPLE", index=1, inputs=inputs[1]).fields()
    assert again == first[1]
    third = link.request("SAMPLE", index=2, inputs=inputs[2]).fields()
    assert link.stats()["replayed"] == 1
    fresh = [r.fields() for r in link.pipeline(("SAMPLE", {"inputs": x}) for x in _rls(link))]
    assert fresh[2]["outputs"] == third["outputs"]  # the repeat did not step the filter


def test_a_sample_out_of_order_is_refused_with_the_index_expected(link) -> None:
    inputs = _rls(link)
    link.request("SAMPLE", index=0, inputs=inputs[0])
    with pytest.raises(BoardError, match="OUT_OF_ORDER") as exc:
        link.request("SAMPLE", index=2, inputs=inputs[2])
    assert exc.value.detail == 1


def test_unknown_request_type_is_an_error(link) -> None:
    link.port.write(frame.encode(0x42, 9, b""))
    reply = link.port.read(64)
    f = frame.decode(reply[:-1], lambda seq: 0x42)  # its CRC covers the request's type
    assert (f.name, f.seq, f.fields()["code"]) == ("ERROR", 9, SCHEMA.error["UNKNOWN_TYPE"])


def test_corrupt_and_oversize_frames_are_counted_and_the_link_recovers(link) -> None:
    bad_crc = bytearray(frame.encode(0x02, 5, b"hello"))
    bad_crc[6] ^= 0x40  # a body byte
    link.port.write(bytes(bad_crc))
    link.port.write(b"\x07" * (frame.WIRE_MAX + 10) + b"\x00")  # no frame is that long
    link.port.write(b"\x02\x00")  # a COBS code that promises more than is there
    with pytest.raises(LinkError, match="OVERSIZE"):
        # no retry: see the board's own report of the long frame, not a retry past it
        link.request("PING", retries=0, payload=b"x")
    assert link.request("PING", payload=b"after").fields()["payload"] == b"after"
    stats = link.stats()
    assert stats["crc_errors"] == 1
    assert stats["oversize"] == 1
    assert stats["cobs_errors"] == 1


def test_frame_counts_go_past_16_bits(link) -> None:
    """The board keeps each 32-bit count as two halves, the high one carried into."""
    before = link.stats()
    n = 2**16 + 5
    list(link.pipeline((("PING", {"payload": b""}) for _ in range(n)), window=256))
    after = link.stats()
    # the PINGs (and any the host sent again), and the STATS request, each answered
    # once (the STATS reply is counted once it is sent)
    received = after["rx_frames"] - before["rx_frames"]
    assert n + 1 <= received < n + 1 + 2**10
    assert after["tx_frames"] - before["tx_frames"] == received


def test_reboot_request_is_acked_and_the_board_announces_itself_again(link) -> None:
    link.request("RESET", what=SCHEMA.reset_what["REBOOT"])
    assert link.wait_ready(1.0)["reset_cause"] == SCHEMA.reset_cause["SOFTWARE"]
    assert link.hello().fields["boot_count"] == 2


def test_a_reply_to_another_request_with_the_same_seq_is_not_taken_as_the_reply(link) -> None:
    seq = link._seq  # the PING below will use it: a STATS reply borrows it first
    link.port.write(frame.encode(SCHEMA.messages["GET_STATS"].type, seq, b""))
    assert link.request("PING", payload=b"mine").fields()["payload"] == b"mine"
    # The STATS reply's CRC covers GET_STATS, not PING: it fails as the PING's answer.
    assert link.decoder.bad_frames == 1 and "CRC" in link.decoder.last_error


def _rls_parts(link, max_body: int) -> list[tuple[str, dict]]:  # noqa: ANN001
    """RLS's CONFIG as frames of at most max_body bytes: its block in parts."""
    from vehil.estimators import stlqf
    from vehil.link import config_requests

    params = stlqf.RLS.encode_params(stlqf.RLS.param_values({}), "F32")
    return config_requests(stlqf.RLS.c_id, SCHEMA.mode["F32"], params, max_body=max_body)


def _send(link, requests: list[tuple[str, dict]]) -> None:  # noqa: ANN001
    for name, fields in requests:
        link.request(name, **fields)


def _steps(link, inputs: list[bytes]) -> list[tuple[int, bytes]]:  # noqa: ANN001
    """Status and outputs of each sample (the native board's cycles are the host's clock)."""
    link.sample_index = 0
    replies = [r.fields() for r in link.pipeline(("SAMPLE", {"inputs": x}) for x in inputs)]
    return [(f["status"], f["outputs"]) for f in replies]


def test_a_config_in_parts_runs_as_the_same_config_in_one_frame(link) -> None:
    inputs = _rls(link)
    whole = _steps(link, inputs)
    parts = _rls_parts(link, max_body=12)  # 8 parameter bytes a frame
    assert [name for name, _ in parts].count("CONFIG_PART") >= 2
    _send(link, parts)
    _send(link, parts[-1:])  # a CONFIG sent again (its ACK lost) applies the same block
    assert _steps(link, inputs) == whole
    with pytest.raises(BoardError, match="OUT_OF_ORDER.*holds 0 parameter bytes"):
        _send(link, parts[-1:])  # a step has reused the parts' memory: not applied again


def test_a_config_part_ends_the_configuration_in_force(link) -> None:
    inputs = _rls(link)
    _send(link, _rls_parts(link, max_body=12)[:1])
    with pytest.raises(BoardError, match="NOT_CONFIGURED"):
        link.request("SAMPLE", index=0, inputs=inputs[0])


def test_parts_out_of_order_or_too_many_are_refused_and_nothing_is_applied(link) -> None:
    inputs = _rls(link)
    parts = _rls_parts(link, max_body=12)
    _send(link, parts[:1])
    with pytest.raises(BoardError, match="OUT_OF_ORDER") as exc:
        _send(link, parts[2:3])  # the second part skipped
    assert exc.value.detail == 8
    with pytest.raises(BoardError, match="OUT_OF_ORDER"):
        _send(link, parts[-1:])  # the CONFIG cannot complete a block with a gap
    with pytest.raises(BoardError, match="NOT_CONFIGURED"):
        link.request("SAMPLE", index=0, inputs=inputs[0])
    name, last = parts[-1]
    with pytest.raises(BoardError, match="BAD_LENGTH"):  # a block one value short
        _send(link, [*parts[:-1], (name, {**last, "params": last["params"][4:]})])
    with pytest.raises(BoardError, match="NOT_CONFIGURED"):
        link.request("SAMPLE", index=0, inputs=inputs[0])
    chunk = bytes(120)
    _send(link, [("CONFIG_PART", {"offset": o, "params": chunk}) for o in range(0, 480, 120)])
    with pytest.raises(BoardError, match="PARAMS_OVERSIZE.*at most 512") as exc:
        link.request("CONFIG_PART", offset=480, params=chunk)
    _send(link, parts)  # the board takes a good block after all that
    assert len(_steps(link, inputs)) == 3
