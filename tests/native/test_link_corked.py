"""Link.corked(): the requests of a burst reach the board in one write, and each is answered."""

from unittest import mock

import pytest

from vehil.boards import BoardOptions, open_board


@pytest.fixture
def link(built):  # noqa: ANN001, ANN201
    with open_board("native", BoardOptions(timeout_s=0.5)) as link:
        yield link


def _burst(link) -> list[bytes]:  # noqa: ANN001
    payloads = [bytes([i + 1]) * 16 for i in range(5)]
    replies = link.pipeline((("PING", {"payload": p}) for p in payloads), window=5)
    got = [r.fields()["payload"] for r in replies]
    assert got == payloads
    return got


@pytest.mark.parametrize(("corked", "writes"), [(True, 1), (False, 5)])
def test_a_corked_burst_goes_out_in_one_write(link, corked: bool, writes: int) -> None:  # noqa: ANN001
    with mock.patch.object(link.port, "write", wraps=link.port.write) as write:
        if corked:
            with link.corked():
                _burst(link)
        else:
            _burst(link)
    assert write.call_count == writes
