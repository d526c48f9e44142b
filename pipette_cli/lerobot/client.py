"""A client of ``pipette serve`` for the evaluation loop (paper A.4): one REQ socket, with timeouts.

A REQ socket that timed out waiting for a reply is stuck (it may not send again), so after a
timeout :class:`PolicyClient` closes it and connects a fresh one; the next request works as soon
as the server answers again. Counting consecutive failures and holding the robot is the
evaluation loop's business.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import numpy as np
import zmq

from pipette_cli.lerobot.protocol import ServingError, pack, unpack

log = logging.getLogger(__name__)

DEFAULT_TIMEOUT_MS = {"act": 65_000, "smolvla": 65_000, "pi0": 300_000}
"""Request timeouts of the paper's clients (A.4), by policy type."""
MAX_REPLY_BYTES = 256 * 2**20


class PolicyTimeout(ServingError):
    """No reply within the client's timeout (the socket has been replaced; retrying is safe)."""


class PolicyRequestError(ServingError):
    """The server answered with an error reply.

    Attributes:
        type: The reply's error type (``bad_shape``, ``nan``, ``internal``, ... see docs/serving.md).
        field: The request field at fault, if any.
    """

    def __init__(self, type: str, message: str, field: str | None = None) -> None:  # noqa: A002
        self.type = type
        self.field = field
        super().__init__(f"policy server: {type}: {message}")


class PolicyClient:
    """Ask a policy server for actions.

    Example::

        with PolicyClient("tcp://127.0.0.1:5555", timeout_ms=DEFAULT_TIMEOUT_MS["act"]) as client:
            action = client.act(obs, task="Close the centrifuge lid", reset=True)  # (8,)
    """

    def __init__(self, endpoint: str = "tcp://127.0.0.1:5555", timeout_ms: int = DEFAULT_TIMEOUT_MS["act"]) -> None:
        """Connect (lazily: the server may start later).

        Args:
            endpoint: The server's ZeroMQ endpoint.
            timeout_ms: How long one request may wait for its reply.
        """
        if timeout_ms <= 0:
            raise ValueError("timeout_ms must be positive")
        self.endpoint = endpoint
        self.timeout_ms = timeout_ms
        self.timeouts = 0
        self._context = zmq.Context()
        self._socket: zmq.Socket | None = None
        self._connect()

    @classmethod
    def for_policy(cls, policy_type: str, endpoint: str = "tcp://127.0.0.1:5555") -> PolicyClient:
        """A client with the paper's timeout for ``act``, ``smolvla`` (65 s) or ``pi0`` (300 s)."""
        try:
            return cls(endpoint, DEFAULT_TIMEOUT_MS[policy_type])
        except KeyError:
            raise ServingError(f"no default timeout for policy type {policy_type!r}; pick one of {sorted(DEFAULT_TIMEOUT_MS)}") from None

    def _connect(self) -> None:
        if self._socket is not None:
            self._socket.close(linger=0)
        self._socket = self._context.socket(zmq.REQ)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.setsockopt(zmq.SNDTIMEO, self.timeout_ms)
        self._socket.connect(self.endpoint)

    def request(self, message: Mapping[str, Any]) -> dict[str, Any]:
        """Send one request map and return the reply map (error replies included).

        Raises:
            PolicyTimeout: No reply within ``timeout_ms``; the socket was recreated.
            ServingError: The reply is not a protocol message.
        """
        assert self._socket is not None, "client is closed"
        try:
            self._socket.send(pack(dict(message)))
            if not self._socket.poll(self.timeout_ms, zmq.POLLIN):
                raise zmq.Again()
            raw = self._socket.recv()
        except zmq.Again:
            self.timeouts += 1
            log.warning("no reply from %s within %d ms; reconnecting", self.endpoint, self.timeout_ms)
            self._connect()
            raise PolicyTimeout(f"no reply from {self.endpoint} within {self.timeout_ms} ms") from None
        reply = unpack(raw, max_bytes=MAX_REPLY_BYTES)
        if not isinstance(reply, dict) or "ok" not in reply:
            raise ServingError(f"{self.endpoint} answered something that is not a policy-server reply")
        return reply

    def info(self) -> dict[str, Any]:
        """The served policy's spec: ``policy_type``, ``images``, ``state_shape``, ``action_dim``, ``chunk_size``."""
        return self._checked(self.request({"command": "info"}))["policy"]

    def act(
        self, observation: Mapping[str, np.ndarray], *, task: str = "", reset: bool = False, chunk: bool = False,
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
            self._socket.close(linger=0)
            self._socket = None
            self._context.term()

    def __enter__(self) -> PolicyClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
