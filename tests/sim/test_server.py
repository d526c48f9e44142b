"""The policy server over real loopback sockets: answers, typed errors, no wedging, timeouts, fuzz."""

from __future__ import annotations

import socket
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import msgpack
import numpy as np
import pytest
import zmq

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fixtures" / "policy"))

from tiny_policy import ConstantRunner, make_tiny_act, observation

from pipette_cli.serving.client import PolicyClient, PolicyRequestError, PolicyTimeout
from pipette_cli.serving.protocol import ErrorType, pack, unpack
from pipette_cli.serving.server import LeRobotRunner, PolicyServer, serving_in_thread

pytestmark = pytest.mark.timeout(60)


@contextmanager
def serving(runner, **kwargs) -> Iterator[PolicyServer]:
    """A server on an OS-chosen loopback port, in a thread, stopped and joined afterwards."""
    with serving_in_thread(PolicyServer(runner, "tcp://127.0.0.1:0", **kwargs)) as server:  # raises if it does not stop
        yield server


@pytest.fixture(scope="module")
def tiny_act(tmp_path_factory) -> Path:
    return make_tiny_act(tmp_path_factory.mktemp("policy") / "act")


def test_a_lerobot_policy_answers_actions_and_chunks(tiny_act) -> None:
    runner = LeRobotRunner(tiny_act, device="cpu")
    assert runner.spec.images == {f"observation.images.{c}": (3, 32, 32) for c in ("top", "main", "wrist")}
    obs_u8 = observation(seed=1)
    obs_f32 = {k: (v / np.float32(255)).astype(np.float32) if v.dtype == np.uint8 else v for k, v in obs_u8.items()}
    with serving(runner) as server, PolicyClient(server.endpoint, timeout_ms=10_000) as client:
        assert client.info()["chunk_size"] == 5
        first = client.act(obs_u8, task="close the lid", reset=True)
        assert first.shape == (8,) and first.dtype == np.float32 and np.isfinite(first).all()
        # float32 images in [0, 1] and the same uint8 images give the same action
        assert np.allclose(client.act(obs_f32, reset=True), first, atol=1e-5)
        chunk = client.act(obs_u8, chunk=True)
        assert chunk.shape == (5, 8) and np.allclose(chunk[0], first, atol=1e-5)
        # the queue of ACT's select_action: the next steps of the same chunk, then a fresh one after reset
        client.act(obs_u8, reset=True)
        assert np.allclose(client.act(observation(seed=2)), chunk[1], atol=1e-5)
        assert np.allclose(
            client.act(observation(seed=2), reset=True), client.act(observation(seed=2), chunk=True)[0], atol=1e-5
        )
    assert server.stats.errors == 0 and server.stats.actions == 7


def test_bad_requests_get_typed_errors_and_the_server_keeps_serving() -> None:
    runner = ConstantRunner()
    with serving(runner, max_request_bytes=200_000) as server, PolicyClient(server.endpoint, timeout_ms=5000) as client:
        good = observation()
        nan_state = good["observation.state"].copy()
        nan_state[0] = np.nan
        cases = {
            "bad_shape": {**good, "observation.images.top": np.zeros((3, 16, 16), np.uint8)},
            "bad_dtype": {**good, "observation.images.top": np.zeros((3, 32, 32), np.float64)},
            "nan": {**good, "observation.state": nan_state},
            "out_of_range": {**good, "observation.images.top": np.full((3, 32, 32), 2.0, np.float32)},
            "too_large": {**good, "observation.images.top": np.zeros((3, 300, 300), np.uint8)},
            "bad_request": {k: v for k, v in good.items() if k != "observation.images.wrist"},
        }
        for kind, obs in cases.items():
            with pytest.raises(PolicyRequestError) as info:
                client.act(obs)
            assert info.value.type == kind, info.value
        assert client.request({"command": "shutdown"})["error"]["type"] == "bad_request"
        assert runner.calls == 0  # nothing bad reached the policy
        assert client.act(good).tolist() == [1.0] * 8
        runner.fail = True
        with pytest.raises(PolicyRequestError, match="policy exploded") as info:
            client.act(good)
        assert info.value.type == "internal"
        runner.fail = False
        assert client.act(good, chunk=True).shape == (5, 8)
    assert server.stats.errors == 8 and server.stats.actions == 2


def test_reset_policy_resets_before_acting() -> None:
    runner = ConstantRunner()
    with serving(runner) as server, PolicyClient(server.endpoint, timeout_ms=5000) as client:
        client.act(observation(), reset=True)
        client.act(observation())
        client.act(observation(), reset=True)
    assert runner.resets == 2 and runner.calls == 3


def test_a_client_that_vanishes_mid_request_does_not_wedge_the_server() -> None:
    runner = ConstantRunner(delay_s=0.3)
    with serving(runner) as server:
        context = zmq.Context.instance()
        for _ in range(2):  # a REQ client that sends and disappears while the policy runs
            runner.started.clear()
            gone = context.socket(zmq.REQ)
            gone.connect(server.endpoint)
            gone.send(pack(observation()))
            assert runner.started.wait(5)
            gone.close(linger=0)
        # a raw TCP peer that sends half a greeting and drops, and a DEALER sending odd frames
        with socket.create_connection(("127.0.0.1", int(server.endpoint.rsplit(":", 1)[1]))) as raw:
            raw.sendall(b"\xff\x00\x00\x00\x00\x00\x00\x00\x01\x7f\x03")
        dealer = context.socket(zmq.DEALER)
        dealer.connect(server.endpoint)
        dealer.send_multipart([b"no-delimiter"])
        assert dealer.poll(5000) and unpack(dealer.recv())["error"]["type"] == "bad_request"
        dealer.send_multipart([b"", b"one", b"two"])
        assert dealer.poll(5000) and dealer.recv_multipart()[0] == b""
        dealer.close(linger=0)
        started = time.monotonic()
        with PolicyClient(server.endpoint, timeout_ms=5000) as client:
            assert client.act(observation()).tolist() == [3.0] * 8  # the third call: the server moved on
        assert time.monotonic() - started < 2.0


def test_the_client_recovers_after_a_timeout() -> None:
    runner = ConstantRunner(delay_s=0.6)
    with serving(runner) as server, PolicyClient(server.endpoint, timeout_ms=150) as client:
        with pytest.raises(PolicyTimeout):
            client.act(observation())
        assert client.timeouts == 1
        runner.delay_s = 0.0
        client.timeout_ms = 5000
        # a REQ socket stuck in "awaiting reply" would refuse to send; the recreated one works, and
        # gets its own reply, not the late answer to the timed-out request (call 1)
        assert client.act(observation()).tolist() == [2.0] * 8


def test_the_client_times_out_without_a_server_and_connects_when_it_starts() -> None:
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    with PolicyClient(f"tcp://127.0.0.1:{port}", timeout_ms=100) as client:
        with pytest.raises(PolicyTimeout):
            client.info()
        server = PolicyServer(ConstantRunner(), f"tcp://127.0.0.1:{port}")
        thread = threading.Thread(target=server.serve_forever, kwargs={"max_requests": 1}, daemon=True)
        thread.start()
        client.timeout_ms = 5000
        assert client.info()["policy_type"] == "constant"
        thread.join(5)
        assert not thread.is_alive()  # max_requests stops the server by itself


def _fuzz_messages(rng: np.random.Generator, n: int) -> Iterator[bytes]:
    valid = pack(observation(seed=3))
    shapes = [(3, 32, 32), (32, 32, 3), (3, 32), (0,), (8,), (2, 8)]
    for i in range(n):
        kind = i % 6
        if kind == 0:  # random bytes
            yield rng.bytes(int(rng.integers(0, 300)))
        elif kind == 1:  # a valid request cut short
            yield valid[: int(rng.integers(0, len(valid)))]
        elif kind == 2:  # a valid request with flipped bytes
            buf = bytearray(valid)
            for pos in rng.integers(0, len(buf), size=int(rng.integers(1, 8))):
                buf[pos] = int(rng.integers(0, 256))
            yield bytes(buf)
        elif kind == 3:  # well-formed msgpack, wrong types
            values = [None, 1, -1.5, "x", b"y", [1, 2], {"a": 1}, True, 2**63 - 1, float("nan")]
            obj = {
                str(k): values[int(rng.integers(len(values)))]
                for k in rng.choice(
                    ["observation.state", "observation.images.top", "task", "reset_policy", "chunk", "command", "zzz"],
                    size=int(rng.integers(0, 4)),
                    replace=False,
                )
            }
            yield msgpack.packb(obj if rng.random() < 0.8 else list(obj.values()))
        elif kind == 4:  # arrays with random shapes, dtypes and NaNs
            obs = observation(seed=i)
            key = str(rng.choice(list(obs)))
            dtype = rng.choice([np.uint8, np.float32, np.float64, np.int16])
            arr = rng.standard_normal(shapes[int(rng.integers(len(shapes)))]).astype(dtype)
            if dtype in (np.float32, np.float64) and arr.size:
                arr.flat[0] = np.nan
            try:
                yield pack({**obs, key: arr})
            except TypeError:
                yield b"\x80"
        else:  # array maps lying about their buffers
            yield msgpack.packb(
                {
                    "observation.state": {
                        "__ndarray__": True,
                        "dtype": str(rng.choice(["<f4", "|O", "<u8"])),
                        "shape": [int(rng.integers(-2, 10**9))],
                        "data": rng.bytes(16),
                    }
                }
            )


def test_the_server_survives_fuzzing() -> None:
    n = 600
    rng = np.random.default_rng(1234)
    runner = ConstantRunner()
    started = time.monotonic()
    seen: set[str] = set()
    with serving(runner, max_request_bytes=64_000) as server, PolicyClient(server.endpoint, timeout_ms=3000) as client:
        sock = zmq.Context.instance().socket(zmq.REQ)
        sock.connect(server.endpoint)
        for payload in _fuzz_messages(rng, n):
            sock.send(payload)
            assert sock.poll(3000), "no reply: the server is wedged or dead"
            reply = unpack(sock.recv())
            if reply["ok"]:
                seen.add("ok")
            else:
                assert reply["error"]["type"] in {e.value for e in ErrorType}
                assert isinstance(reply["error"]["message"], str)
                seen.add(reply["error"]["type"])
        sock.close(linger=0)
        assert client.act(observation()).shape == (8,)
        elapsed = time.monotonic() - started
    assert server.stats.requests == n + 1
    assert {"bad_request", "bad_shape", "bad_dtype", "nan"} <= seen and "internal" not in seen
    assert elapsed < 30


def test_a_message_over_the_hard_cap_drops_that_peer_only() -> None:
    runner = ConstantRunner()
    with serving(runner, max_request_bytes=10_000) as server:
        with PolicyClient(server.endpoint, timeout_ms=300) as client:
            with pytest.raises(PolicyTimeout):  # 1 MB > 2 x 10 kB: ZeroMQ cuts the connection, no reply
                client.request({"blob": b"\0" * 1_000_000})
            client.timeout_ms = 5000
            assert (
                client.request({"blob": b"\0" * 15_000})["error"]["type"] == "too_large"
            )  # over the limit, under the cap
            assert client.act(observation()).tolist() == [1.0] * 8
