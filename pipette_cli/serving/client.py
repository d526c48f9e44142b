"""A client of ``pipette serve`` for the evaluation loop (paper A.4): one REQ socket, with timeouts
and a liveness check.

A REQ socket that timed out waiting for a reply is stuck (it may not send again), so after a
timeout :class:`PolicyClient` closes it and connects a fresh one; the next request works as soon
as the server answers again. Counting consecutive failures and holding the robot is the
evaluation loop's business.

Dead or unreachable servers are told apart from slow ones without waiting for the paper's long
timeouts (65 s, pi0 300 s). The socket sends ZeroMQ heartbeats (ZMTP PING every
``heartbeat_ms``): the server's ZeroMQ I/O thread answers them even while its policy computes,
so a slow policy stays connected, while a killed process drops the connection at once and a
stopped or cut-off one stops answering and is dropped after ``3 * heartbeat_ms``. A socket
monitor reports connections (ZMTP handshake done) and disconnections. A request on a connection
that is down waits at most ``dead_after_s`` for the server to come back and then raises
:class:`PolicyUnreachable`; a reply lost to a dropped connection raises :class:`PolicyTimeout`
(retry) once the connection is back. A server whose process is alive but whose policy hangs
looks like a slow one and gets the full timeout.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import zmq
from zmq.utils.monitor import recv_monitor_message

from pipette_cli.serving.protocol import (
    DEFAULT_DEAD_AFTER_S,
    DEFAULT_TIMEOUT_MS,
    ServingError,
    pack,
    unpack,
)

log = logging.getLogger(__name__)

MAX_REPLY_BYTES = 256 * 2**20
DEFAULT_HEARTBEAT_MS = 1000
"""ZMTP heartbeat interval; a connection that answers none for 3 intervals is dropped."""


class PolicyTimeout(ServingError):
    """No reply within the client's timeout (the socket has been replaced; retrying is safe)."""


class PolicyUnreachable(ServingError):
    """No connection to the server for ``dead_after_s``: it is down, stopped or cut off."""


class PolicyRequestError(ServingError):
    """The server answered with an error reply.

    Attributes:
        type: The reply's error type (``bad_shape``, ``nan``, ``internal``, ... see docs/serving.md).
        field: The request field at fault, if any.
    """

    def __init__(self, type: str, message: str, field: str | None = None) -> None:
        self.type = type
        self.field = field
        super().__init__(f"policy server: {type}: {message}")


class PolicyClient:
    """Ask a policy server for actions.

    Example::

        with PolicyClient("tcp://127.0.0.1:5555", timeout_ms=DEFAULT_TIMEOUT_MS["act"]) as client:
            action = client.act(obs, task="Close the centrifuge lid", reset=True)  # (8,)
    """

    def __init__(
        self,
        endpoint: str = "tcp://127.0.0.1:5555",
        timeout_ms: int = DEFAULT_TIMEOUT_MS["act"],
        *,
        heartbeat_ms: int = DEFAULT_HEARTBEAT_MS,
        dead_after_s: float = DEFAULT_DEAD_AFTER_S,
    ) -> None:
        """Connect (lazily: the server may start later; see :meth:`wait_until_up`).

        Args:
            endpoint: The server's ZeroMQ endpoint.
            timeout_ms: How long one request may wait for its reply (connection waits included).
            heartbeat_ms: Interval of ZMTP heartbeats; a connection silent for 3 of them is dropped.
            dead_after_s: How long a request waits for a connection that is down before it
                raises :class:`PolicyUnreachable`.
        """
        if timeout_ms <= 0 or heartbeat_ms <= 0 or dead_after_s <= 0:
            raise ValueError("timeout_ms, heartbeat_ms and dead_after_s must be positive")
        self.endpoint = endpoint
        self.timeout_ms = timeout_ms
        self.heartbeat_ms = heartbeat_ms
        self.dead_after_s = dead_after_s
        self.timeouts = 0
        self._context = zmq.Context()
        self._socket: zmq.Socket | None = None
        self._monitor: zmq.Socket | None = None
        self._up = False
        self._down_since = time.monotonic()
        self._connect()

    @classmethod
    def for_policy(cls, policy_type: str, endpoint: str = "tcp://127.0.0.1:5555") -> PolicyClient:
        """A client with the paper's timeout for ``act``, ``smolvla`` (65 s) or ``pi0`` (300 s)."""
        try:
            return cls(endpoint, DEFAULT_TIMEOUT_MS[policy_type])
        except KeyError:
            raise ServingError(
                f"no default timeout for policy type {policy_type!r}; pick one of {sorted(DEFAULT_TIMEOUT_MS)}"
            ) from None

    def _connect(self) -> None:
        self._close_sockets()
        self._socket = self._context.socket(zmq.REQ)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.setsockopt(zmq.SNDTIMEO, self.timeout_ms)
        self._socket.setsockopt(zmq.HEARTBEAT_IVL, self.heartbeat_ms)
        self._socket.setsockopt(zmq.HEARTBEAT_TIMEOUT, 3 * self.heartbeat_ms)
        self._monitor = self._socket.get_monitor_socket(zmq.EVENT_HANDSHAKE_SUCCEEDED | zmq.EVENT_DISCONNECTED)
        if self._up:  # a fresh socket starts down; the server is presumed gone from now
            self._up, self._down_since = False, time.monotonic()
        self._socket.connect(self.endpoint)

    def _close_sockets(self) -> None:
        if self._socket is not None:
            self._socket.disable_monitor()
            self._socket.close(linger=0)
            self._socket = None
        if self._monitor is not None:
            self._monitor.close(linger=0)
            self._monitor = None

    def _read_events(self, wait_ms: int = 0) -> bool:
        """Apply the monitor's pending events (waiting up to ``wait_ms`` for the first); True if a
        connection was lost among them."""
        assert self._monitor is not None
        lost = False
        while self._monitor.poll(wait_ms, zmq.POLLIN):
            wait_ms = 0
            event = recv_monitor_message(self._monitor)["event"]
            if event == zmq.EVENT_HANDSHAKE_SUCCEEDED:
                self._up = True
            elif event == zmq.EVENT_DISCONNECTED and self._up:
                lost = True
                self._up, self._down_since = False, time.monotonic()
        return lost

    @property
    def connected(self) -> bool:
        """Whether a connection to the server is up (after applying pending monitor events)."""
        self._read_events()
        return self._up

    def wait_until_up(self, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for a connection to the server; True once there is one."""
        deadline = time.monotonic() + timeout_s
        while not self.connected:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self._read_events(int(min(left, 0.1) * 1000) + 1)
        return True

    def _wait_for_connection(self, deadline: float) -> None:
        """Return once connected; raise if the server stays down past ``dead_after_s`` or ``deadline``."""
        while not self.connected:
            now = time.monotonic()
            dead_at = self._down_since + self.dead_after_s
            if now >= dead_at:
                raise PolicyUnreachable(
                    f"no connection to {self.endpoint} for {now - self._down_since:.0f} s: "
                    "the policy server is down or unreachable"
                )
            if now >= deadline:
                raise PolicyTimeout(f"no connection to {self.endpoint} within {self.timeout_ms} ms")
            self._read_events(int(1000 * min(dead_at - now, deadline - now, 0.1)) + 1)

    def request(self, message: Mapping[str, Any]) -> dict[str, Any]:
        """Send one request map and return the reply map (error replies included).

        Raises:
            PolicyUnreachable: No connection to the server for ``dead_after_s``.
            PolicyTimeout: No reply within ``timeout_ms``, or the connection dropped while
                waiting and came back; the socket was recreated and a retry is safe.
            ServingError: The reply is not a protocol message.
        """
        assert self._socket is not None, "client is closed"
        deadline = time.monotonic() + self.timeout_ms / 1000
        self._wait_for_connection(deadline)
        try:
            self._socket.send(pack(dict(message)))
            raw = self._await_reply(deadline)
        except zmq.Again:
            self.timeouts += 1
            log.warning("no reply from %s within %d ms; reconnecting", self.endpoint, self.timeout_ms)
            self._connect()
            raise PolicyTimeout(f"no reply from {self.endpoint} within {self.timeout_ms} ms") from None
        reply = unpack(raw, max_bytes=MAX_REPLY_BYTES)
        if not isinstance(reply, dict) or "ok" not in reply:
            raise ServingError(f"{self.endpoint} answered something that is not a policy-server reply")
        return reply

    def _await_reply(self, deadline: float) -> bytes:
        """The reply to the request just sent; a dropped connection raises instead of waiting on."""
        assert self._socket is not None and self._monitor is not None
        poller = zmq.Poller()
        poller.register(self._socket, zmq.POLLIN)
        poller.register(self._monitor, zmq.POLLIN)
        while True:
            left_ms = int(1000 * (deadline - time.monotonic()))
            if left_ms <= 0:
                raise zmq.Again()
            ready = dict(poller.poll(left_ms))
            if self._socket in ready:
                return self._socket.recv()
            if self._monitor in ready and self._read_events():
                break
        # The connection carrying the request dropped: the reply can never come on this socket.
        self.timeouts += 1
        log.warning("connection to %s dropped while waiting for a reply", self.endpoint)
        self._connect()
        self._wait_for_connection(deadline)
        raise PolicyTimeout(f"the connection to {self.endpoint} dropped while waiting for a reply")

    def info(self) -> dict[str, Any]:
        """The served policy's spec: ``policy_type``, ``images``, ``state_shape``, ``action_dim``, ``chunk_size``."""
        return self._checked(self.request({"command": "info"}))["policy"]

    def act(
        self,
        observation: Mapping[str, np.ndarray],
        *,
        task: str = "",
        reset: bool = False,
        chunk: bool = False,
    ) -> np.ndarray:
        """One action ``(A,)``, or with ``chunk`` an action chunk ``(K, A)``, for an observation.

        Args:
            observation: ``observation.images.<camera>`` (CHW uint8, or float32 in [0, 1]) and
                ``observation.state``.
            task: The language instruction.
            reset: Reset the policy first (the first step of an episode).
            chunk: Ask for the whole action chunk.

        Raises:
            PolicyRequestError: The server refused the request or the policy failed.
            PolicyTimeout: No reply in time.
        """
        reply = self._checked(self.request({**observation, "task": task, "reset_policy": reset, "chunk": chunk}))
        return np.asarray(reply["action"], dtype=np.float32)

    @staticmethod
    def _checked(reply: dict[str, Any]) -> dict[str, Any]:
        if reply.get("ok") is True:
            return reply
        error = reply.get("error") or {}
        raise PolicyRequestError(str(error.get("type", "unknown")), str(error.get("message", "")), error.get("field"))

    def close(self) -> None:
        """Close the socket and context."""
        if self._socket is not None:
            self._close_sockets()
            self._context.term()

    def __enter__(self) -> PolicyClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
