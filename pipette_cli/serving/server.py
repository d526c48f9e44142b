"""The policy server behind ``pipette serve`` (paper A.4): a LeRobot policy answering over ZeroMQ.

Clients use REQ sockets (:class:`~pipette_cli.serving.client.PolicyClient`); the server uses a
ROUTER socket, so it is never wedged: each request is answered from its own envelope, a reply to
a client that has gone away is dropped by ZeroMQ, and a malformed, oversized or unanswerable
request gets a typed error reply (``docs/serving.md``) while the server goes on serving.
Requests are served one at a time, in arrival order.
"""

from __future__ import annotations

import contextlib
import io
import ipaddress
import logging
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import zmq

from pipette_cli.serving.protocol import (
    DEFAULT_DEVICE,
    DEFAULT_ENDPOINT,
    DEFAULT_MAX_REQUEST_BYTES,
    STATE_KEY,
    ErrorType,
    InfoRequest,
    PolicySpec,
    ProtocolError,
    ServingError,
    action_reply,
    check_observation,
    error_reply,
    info_reply,
    pack,
    parse_request,
    unpack,
)

log = logging.getLogger(__name__)

_LOOPBACK_NAMES = {"localhost"}


class PolicyRunner(Protocol):
    """A policy the server can run: its :class:`PolicySpec`, ``reset`` and ``act``."""

    spec: PolicySpec

    def reset(self) -> None:
        """Forget the episode (action queue, temporal state)."""

    def act(self, observation: dict[str, np.ndarray], task: str, *, chunk: bool) -> np.ndarray:
        """One action ``(A,)`` or, with ``chunk``, an action chunk ``(K, A)`` for a checked observation."""


class LeRobotRunner:
    """A LeRobot policy with its saved pre/post-processors (as ``lerobot-eval`` loads them).

    uint8 images become float32 / 255; the preprocessor normalises and moves the batch to the
    device; ``select_action`` (one action) or ``predict_action_chunk`` (a chunk) runs; the
    postprocessor unnormalises.
    """

    def __init__(self, path: Path, *, device: str = DEFAULT_DEVICE) -> None:
        """Load the policy saved in ``path`` (a ``save_pretrained`` folder) onto ``device``.

        Raises:
            ServingError: The folder is missing or not a LeRobot policy with processors.
        """
        # deferred: torch, lerobot (~3 s; a server or client without a LeRobot policy never needs them)
        import torch
        from lerobot.configs.types import FeatureType

        path = Path(path)
        if not (path / "config.json").is_file():
            raise ServingError(
                f"{path}: not a LeRobot policy folder (no config.json); pass the pretrained_model folder"
            )
        if device == "auto":
            device = "cuda" if torch.cuda.is_available() else "cpu"
        printed = io.StringIO()  # LeRobot prints while loading; stdout is for results
        try:
            with contextlib.redirect_stdout(printed):
                config, policy, processors = _load(path, device)
        except Exception as exc:  # draccus, safetensors, torch: any failure is an unusable folder
            raise ServingError(f"{path}: cannot load the policy: {exc}".splitlines()[0]) from exc
        finally:
            log.debug("loading %s: %s", path, printed.getvalue().strip())
        self.policy, self.device, self._torch = policy, device, torch
        self.preprocessor, self.postprocessor = processors
        feats = config.input_features
        state = feats.get(STATE_KEY)
        self.spec = PolicySpec(
            policy_type=config.type,
            images={k: tuple(f.shape) for k, f in feats.items() if f.type is FeatureType.VISUAL},
            state_shape=tuple(state.shape) if state is not None else (0,),
            action_dim=int(config.output_features["action"].shape[0]),
            chunk_size=int(getattr(config, "chunk_size", None) or getattr(config, "n_action_steps", None) or 1),
        )

    def reset(self) -> None:
        self.policy.reset()

    def act(self, observation: dict[str, np.ndarray], task: str, *, chunk: bool) -> np.ndarray:
        torch = self._torch
        batch: dict[str, Any] = {"task": [task]}
        for key, arr in observation.items():
            if arr.dtype == np.uint8:  # as LeRobot datasets load frames: float32 / 255
                arr = np.divide(arr, np.float32(255), dtype=np.float32)
            else:
                arr = np.array(arr, dtype=np.float32)  # a writable copy of the read-only wire buffer
            batch[key] = torch.from_numpy(arr).unsqueeze(0)
        with torch.inference_mode():
            batch = self.preprocessor(batch)
            if chunk:
                actions = self.policy.predict_action_chunk(batch)[0]  # (K, A): the chunk as a batch
            else:
                actions = self.policy.select_action(batch)  # (1, A)
            actions = self.postprocessor(actions)
        actions = actions.detach().to("cpu").numpy().astype(np.float32)
        return actions if chunk else actions[0]


def _load(path: Path, device: str) -> tuple[Any, Any, tuple[Any, Any]]:
    """Config, policy (eval mode, on ``device``) and pre/post-processors, as ``lerobot-eval`` loads them."""
    # deferred: lerobot, torch (as above)
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.policies.factory import get_policy_class, make_pre_post_processors

    config = PreTrainedConfig.from_pretrained(path, local_files_only=True)
    config.device = device
    policy = get_policy_class(config.type).from_pretrained(path, config=config, local_files_only=True)
    policy.to(device).eval()
    processors = make_pre_post_processors(
        config,
        pretrained_path=str(path),
        preprocessor_overrides={"device_processor": {"device": device}},
    )
    return config, policy, processors


@dataclass
class ServerStats:
    """Counters of a running server."""

    requests: int = 0
    actions: int = 0
    errors: int = 0
    inference_s: float = 0.0


def check_endpoint(endpoint: str, *, allow_remote: bool = False) -> None:
    """Refuse to bind beyond this machine unless asked: ``tcp://`` needs a loopback host.

    Raises:
        ServingError: A non-loopback TCP host (``0.0.0.0``, ``*``, a LAN address) without
            ``allow_remote``, or a malformed endpoint.
    """
    transport, sep, rest = endpoint.partition("://")
    if not sep or transport not in {"tcp", "ipc", "inproc"}:
        raise ServingError(f"endpoint {endpoint!r} must look like tcp://127.0.0.1:5555 (or ipc://, inproc://)")
    if transport != "tcp":
        return
    host, _, port = rest.rpartition(":")
    if not host or not port:
        raise ServingError(f"endpoint {endpoint!r} needs a host and a port, e.g. tcp://127.0.0.1:5555")
    host = host.strip("[]")
    try:
        loopback = ipaddress.ip_address(host).is_loopback
    except ValueError:
        loopback = host in _LOOPBACK_NAMES
    if not loopback and not allow_remote:
        raise ServingError(
            f"{endpoint} would expose the policy server beyond this machine; "
            "bind tcp://127.0.0.1:PORT or pass --allow-remote (the server has no authentication)"
        )


class PolicyServer:
    """Serve a :class:`PolicyRunner` on a ROUTER socket until :meth:`stop` (thread-safe) is called.

    Example::

        server = PolicyServer(LeRobotRunner(Path("outputs/act/pretrained_model")), "tcp://127.0.0.1:0")
        print(server.endpoint)  # the port the OS chose
        server.serve_forever()
    """

    def __init__(
        self,
        runner: PolicyRunner,
        endpoint: str = DEFAULT_ENDPOINT,
        *,
        allow_remote: bool = False,
        max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES,
    ) -> None:
        """Bind the socket (port 0 asks the OS for a free port; see :attr:`endpoint`).

        Raises:
            ServingError: A non-loopback endpoint without ``allow_remote``, or the address is in use.
        """
        check_endpoint(endpoint, allow_remote=allow_remote)
        self.runner = runner
        self.max_request_bytes = max_request_bytes
        self.stats = ServerStats()
        self._stop = threading.Event()
        self._context = zmq.Context()
        self._socket = self._context.socket(zmq.ROUTER)
        self._socket.setsockopt(zmq.LINGER, 0)
        # Hard cap: ZeroMQ drops peers sending more, so memory stays bounded; below it, too_large is answered.
        self._socket.setsockopt(zmq.MAXMSGSIZE, 2 * max_request_bytes + 4096)
        self._socket.setsockopt(zmq.SNDTIMEO, 1000)  # never block on a slow reader
        if endpoint.startswith("tcp://") and endpoint.endswith(":0"):
            endpoint = endpoint[:-2] + ":*"
        try:
            self._socket.bind(endpoint)
        except zmq.ZMQError as exc:
            self.close()
            raise ServingError(f"cannot bind {endpoint}: {exc}") from None
        self.endpoint: str = self._socket.getsockopt_string(zmq.LAST_ENDPOINT)

    def stop(self) -> None:
        """Ask :meth:`serve_forever` to return (from any thread or a signal handler)."""
        self._stop.set()

    def close(self) -> None:
        """Close the socket and its context."""
        self._socket.close(linger=0)
        self._context.term()

    def serve_forever(
        self, *, max_requests: int | None = None, on_request: Callable[[ServerStats], None] | None = None
    ) -> ServerStats:
        """Answer requests until :meth:`stop` (or ``max_requests``); closes the socket on return.

        Args:
            max_requests: Return after this many requests (answered or not); None serves forever.
            on_request: Called with the counters after each request.

        Returns:
            The final counters.
        """
        poller = zmq.Poller()
        poller.register(self._socket, zmq.POLLIN)
        try:
            while not self._stop.is_set() and (max_requests is None or self.stats.requests < max_requests):
                if not poller.poll(100):
                    continue
                frames = self._socket.recv_multipart(copy=False)
                self._handle(frames)
                if on_request is not None:
                    on_request(self.stats)
        finally:
            self.close()
        return self.stats

    def _handle(self, frames: list[zmq.Frame]) -> None:
        # A REQ peer's message is [identity, b"", body]; the envelope is everything up to the empty frame.
        split = next((i for i, f in enumerate(frames[1:], 1) if len(f) == 0), None)
        envelope = [f.bytes for f in frames[: split + 1]] if split is not None else [frames[0].bytes]
        body = frames[split + 1 :] if split is not None else frames[1:]
        self.stats.requests += 1
        try:
            if len(body) != 1:
                raise ProtocolError(ErrorType.BAD_REQUEST, f"a request is one message frame, got {len(body)}")
            reply = self._answer(body[0].buffer)
        except ProtocolError as exc:
            self.stats.errors += 1
            log.info("request %d refused: %s %s", self.stats.requests, exc.type.value, exc)
            reply = error_reply(exc)
        except Exception as exc:  # the policy failed: say so and keep serving
            self.stats.errors += 1
            log.exception("request %d failed", self.stats.requests)
            reply = error_reply(ProtocolError(ErrorType.INTERNAL, f"{type(exc).__name__}: {exc}"[:500]))
        try:
            self._socket.send_multipart([*envelope, pack(reply)])
        except zmq.ZMQError as exc:  # the peer is gone or not reading; drop the reply
            log.info("reply %d dropped: %s", self.stats.requests, exc)

    def _answer(self, body: memoryview) -> dict[str, Any]:
        request = parse_request(unpack(body, max_bytes=self.max_request_bytes))
        if isinstance(request, InfoRequest):
            return info_reply(self.runner.spec)
        observation = check_observation(request, self.runner.spec)
        if request.reset_policy:
            self.runner.reset()
        started = time.perf_counter()
        action = np.asarray(self.runner.act(observation, request.task, chunk=request.chunk))
        elapsed = time.perf_counter() - started
        self.stats.inference_s += elapsed
        if not np.isfinite(action).all():
            raise ProtocolError(ErrorType.INTERNAL, "the policy produced NaN or infinite actions")
        self.stats.actions += 1
        return action_reply(action, step=self.stats.actions, inference_ms=elapsed * 1000)


@contextlib.contextmanager
def serving_in_thread(server: PolicyServer, *, join_s: float = 5.0) -> Iterator[PolicyServer]:
    """Serve ``server`` from a daemon thread for the duration of the block (tests, benchmarks,
    notebooks): stopped and joined on exit.

    Raises:
        RuntimeError: the thread did not stop within ``join_s`` seconds.
    """
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield server
    finally:
        server.stop()
        thread.join(timeout=join_s)
    if thread.is_alive():
        raise RuntimeError(f"policy server on {server.endpoint} did not stop within {join_s} s")
