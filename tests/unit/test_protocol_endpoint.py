"""The server binds to this machine only, unless told otherwise."""

from __future__ import annotations

import pytest

from pipette_cli.serving.protocol import ServingError
from pipette_cli.serving.server import check_endpoint


@pytest.mark.parametrize(
    "endpoint",
    [
        "tcp://127.0.0.1:5555",
        "tcp://127.3.2.1:0",
        "tcp://localhost:5555",
        "tcp://[::1]:5555",
        "ipc:///tmp/pipette.sock",
        "inproc://policy",
    ],
)
def test_loopback_and_local_endpoints_are_allowed(endpoint) -> None:
    check_endpoint(endpoint)


@pytest.mark.parametrize(
    "endpoint", ["tcp://0.0.0.0:5555", "tcp://*:5555", "tcp://192.168.1.20:5555", "tcp://eth0:5555", "tcp://[::]:5555"]
)
def test_network_endpoints_need_allow_remote(endpoint) -> None:
    with pytest.raises(ServingError, match="--allow-remote"):
        check_endpoint(endpoint)
    check_endpoint(endpoint, allow_remote=True)


@pytest.mark.parametrize("endpoint", ["127.0.0.1:5555", "udp://127.0.0.1:5555", "tcp://127.0.0.1"])
def test_malformed_endpoints_are_refused(endpoint) -> None:
    with pytest.raises(ServingError):
        check_endpoint(endpoint)
