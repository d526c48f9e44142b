"""Wire format of the policy server (paper A.4): msgpack maps with raw numpy buffers, never pickle.

A numpy array travels as the map ``{"__ndarray__": true, "dtype": "|u1", "shape": [3, H, W],
"data": <bin>}`` (the layout openpi's ``msgpack_numpy`` uses). Decoding accepts only the dtypes in
:data:`ARRAY_DTYPES`, checks that the buffer length matches the shape, and never runs code from
the message: unpickling network input would. Requests and replies are described in
``docs/serving.md``; every problem with a request becomes a :class:`ProtocolError` whose
:class:`ErrorType` goes back to the client in an error reply.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Literal

import msgpack
import numpy as np
from pydantic import AliasChoices, BaseModel, ConfigDict, Field, ValidationError, field_validator

from pipette_cli.errors import PipetteError

PROTOCOL_VERSION = 1
IMAGE_KEYS = ("observation.images.top", "observation.images.main", "observation.images.wrist")
STATE_KEY = "observation.state"
ARRAY_DTYPES = {"|u1": np.uint8, "<f4": np.float32, "<f8": np.float64}
"""Wire dtypes a request may carry (little-endian); anything else is ``bad_dtype``."""
DEFAULT_MAX_REQUEST_BYTES = 64 * 2**20
DEFAULT_ENDPOINT = "tcp://127.0.0.1:5555"
"""Where a server binds and a client connects by default (paper A.4)."""
DEFAULT_DEVICE = "auto"
"""Torch device a policy is loaded on: ``auto`` is cuda when available, else cpu."""
DEFAULT_TIMEOUT_MS = {"act": 65_000, "smolvla": 65_000, "pi0": 300_000}
"""Request timeouts of the paper's clients (A.4), by policy type."""
DEFAULT_DEAD_AFTER_S = 5.0
"""How long a request waits for a lost connection to come back before the server counts as dead."""
MAX_DIMS = 4


class ServingError(PipetteError):
    """The policy server or client cannot do what was asked (load, bind, connect, answer)."""


class ErrorType(StrEnum):
    """The ``type`` of an error reply."""

    BAD_REQUEST = "bad_request"  # not msgpack, not a map, unknown or missing field, wrong field type
    BAD_DTYPE = "bad_dtype"  # an array dtype the field does not accept
    BAD_SHAPE = "bad_shape"  # an array shape the policy does not expect
    NAN = "nan"  # NaN or infinity in an array
    OUT_OF_RANGE = "out_of_range"  # float32 image outside [0, 1]
    TOO_LARGE = "too_large"  # the request is over the server's size limit
    INTERNAL = "internal"  # the policy failed; the server keeps serving


class ProtocolError(ServingError):
    """A request the server rejects; becomes an error reply of type :attr:`type`."""

    def __init__(self, type: ErrorType, message: str, field: str | None = None) -> None:
        self.type = ErrorType(type)
        self.field = field
        super().__init__(f"{field}: {message}" if field else message)


@dataclass(frozen=True)
class PolicySpec:
    """What a served policy expects and answers.

    Attributes:
        policy_type: LeRobot policy type (``act``, ``smolvla``, ``pi0``) or a test stand-in.
        images: Request key -> CHW shape, for each camera the policy reads.
        state_shape: Shape of ``observation.state``.
        action_dim: Length of one action.
        chunk_size: Actions in one chunk reply.
    """

    policy_type: str
    images: dict[str, tuple[int, ...]]
    state_shape: tuple[int, ...]
    action_dim: int
    chunk_size: int

    def as_dict(self) -> dict[str, Any]:
        """The spec as plain msgpack/JSON types (the ``info`` reply)."""
        return {
            "policy_type": self.policy_type,
            "images": {k: list(v) for k, v in self.images.items()},
            "state_shape": list(self.state_shape),
            "action_dim": self.action_dim,
            "chunk_size": self.chunk_size,
        }


# --------------------------------------------------------------------------- encoding


def _encode(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind not in "biuf":
            raise TypeError(f"cannot send an array of dtype {obj.dtype}")
        arr = np.ascontiguousarray(obj)
        return {"__ndarray__": True, "dtype": arr.dtype.str, "shape": list(arr.shape), "data": arr.data}
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"cannot send {type(obj).__name__}")


def _decode_array(obj: dict[str, Any]) -> Any:
    if "__ndarray__" not in obj:
        return obj
    if set(obj) != {"__ndarray__", "dtype", "shape", "data"}:
        raise ProtocolError(ErrorType.BAD_REQUEST, "array maps have exactly __ndarray__, dtype, shape and data")
    dtype, shape, data = obj["dtype"], obj["shape"], obj["data"]
    if dtype not in ARRAY_DTYPES:
        raise ProtocolError(ErrorType.BAD_DTYPE, f"array dtype {dtype!r} is not one of {sorted(ARRAY_DTYPES)}")
    if (
        not isinstance(shape, list)
        or len(shape) > MAX_DIMS
        or not all(type(n) is int and 0 <= n < 2**31 for n in shape)
    ):
        raise ProtocolError(ErrorType.BAD_REQUEST, f"array shape must be at most {MAX_DIMS} non-negative integers")
    if not isinstance(data, bytes):
        raise ProtocolError(ErrorType.BAD_REQUEST, "array data must be msgpack bin")
    itemsize = np.dtype(ARRAY_DTYPES[dtype]).itemsize
    if math.prod(shape) * itemsize != len(data):
        raise ProtocolError(ErrorType.BAD_SHAPE, f"{len(data)} bytes of data do not fill shape {shape} of {dtype}")
    return np.frombuffer(data, dtype=ARRAY_DTYPES[dtype]).reshape(shape)


def pack(obj: Any) -> bytes:
    """Serialise a message (maps, lists, str, numbers, bool, None, numpy arrays) to msgpack bytes."""
    return msgpack.packb(obj, default=_encode, use_bin_type=True)


def unpack(buf: bytes | memoryview, *, max_bytes: int = DEFAULT_MAX_REQUEST_BYTES) -> Any:
    """Deserialise one msgpack message, rebuilding numpy arrays (read-only views of the buffer).

    Raises:
        ProtocolError: ``too_large`` over ``max_bytes``; ``bad_request`` for anything that is not
            one complete msgpack value; ``bad_dtype``/``bad_shape`` for an unacceptable array.
    """
    if len(buf) > max_bytes:
        raise ProtocolError(ErrorType.TOO_LARGE, f"request of {len(buf)} bytes is over the limit of {max_bytes}")
    try:
        return msgpack.unpackb(buf, raw=False, object_hook=_decode_array, strict_map_key=True)
    except ProtocolError:
        raise
    except Exception as exc:  # msgpack raises several unrelated types for garbage input
        raise ProtocolError(
            ErrorType.BAD_REQUEST, f"not a msgpack message ({type(exc).__name__}: {exc})"[:300]
        ) from None


# --------------------------------------------------------------------------- requests


class _Request(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, arbitrary_types_allowed=True, populate_by_name=True)


class InfoRequest(_Request):
    """``{"command": "info"}``: what the served policy expects (answered with :meth:`PolicySpec.as_dict`)."""

    command: Literal["info"]


class ActRequest(_Request):
    """One observation (paper A.4); the reply is one action or, with ``chunk``, an action chunk."""

    command: Literal["act"] = "act"
    image_top: np.ndarray | None = Field(None, alias="observation.images.top")
    image_main: np.ndarray | None = Field(None, alias="observation.images.main")
    image_wrist: np.ndarray | None = Field(None, alias="observation.images.wrist")
    state: np.ndarray = Field(alias="observation.state")
    task: str = Field("", max_length=2000, validation_alias=AliasChoices("task", "language_instruction"))
    reset_policy: bool = False
    chunk: bool = False

    @field_validator("reset_policy", "chunk", mode="before")
    @classmethod
    def _strict_bool(cls, value: Any) -> Any:
        if not isinstance(value, bool):
            raise ValueError("must be true or false")
        return value

    def images(self) -> dict[str, np.ndarray]:
        """The cameras present, by request key."""
        found = zip(IMAGE_KEYS, (self.image_top, self.image_main, self.image_wrist), strict=True)
        return {key: img for key, img in found if img is not None}


def parse_request(obj: Any) -> InfoRequest | ActRequest:
    """Validate a decoded message against the request schema.

    Raises:
        ProtocolError: ``bad_request`` naming the first offending field.
    """
    if not isinstance(obj, dict):
        raise ProtocolError(ErrorType.BAD_REQUEST, f"a request is a msgpack map, not {type(obj).__name__}")
    command = obj.get("command", "act")
    requests: dict[str, type[InfoRequest] | type[ActRequest]] = {"info": InfoRequest, "act": ActRequest}
    model = requests.get(command) if isinstance(command, str) else None
    if model is None:
        raise ProtocolError(ErrorType.BAD_REQUEST, "command must be 'act' or 'info'", "command")
    try:
        return model.model_validate(obj)
    except ValidationError as exc:
        first = exc.errors()[0]
        field = ".".join(str(p) for p in first["loc"]) or None
        raise ProtocolError(ErrorType.BAD_REQUEST, first["msg"], field) from None


def check_observation(request: ActRequest, spec: PolicySpec) -> dict[str, np.ndarray]:
    """Check an observation against the policy: cameras, shapes, dtypes, finite values, [0, 1] floats.

    Returns:
        Request key -> array for the cameras the policy reads (others are ignored) and the state.

    Raises:
        ProtocolError: ``bad_request`` (a camera missing), ``bad_shape``, ``bad_dtype``, ``nan`` or
            ``out_of_range``, naming the field.
    """
    images = request.images()
    out: dict[str, np.ndarray] = {}
    for key, shape in spec.images.items():
        img = images.get(key)
        if img is None:
            raise ProtocolError(ErrorType.BAD_REQUEST, f"missing; this policy reads {sorted(spec.images)}", key)
        if img.dtype not in (np.uint8, np.float32):
            raise ProtocolError(ErrorType.BAD_DTYPE, f"images are uint8 or float32 in [0, 1], not {img.dtype}", key)
        if img.shape != tuple(shape):
            raise ProtocolError(ErrorType.BAD_SHAPE, f"expected CHW shape {tuple(shape)}, got {img.shape}", key)
        if img.dtype == np.float32:
            lo, hi = float(img.min(initial=0.0)), float(img.max(initial=0.0))
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise ProtocolError(ErrorType.NAN, "NaN or infinite pixel values", key)
            if lo < 0.0 or hi > 1.0:
                raise ProtocolError(
                    ErrorType.OUT_OF_RANGE, f"float32 images are in [0, 1], got [{lo:.3g}, {hi:.3g}]", key
                )
        out[key] = img
    state = request.state
    if state.dtype not in (np.float32, np.float64):
        raise ProtocolError(ErrorType.BAD_DTYPE, f"state is float32 or float64, not {state.dtype}", STATE_KEY)
    if state.shape != tuple(spec.state_shape):
        raise ProtocolError(
            ErrorType.BAD_SHAPE, f"expected shape {tuple(spec.state_shape)}, got {state.shape}", STATE_KEY
        )
    if not np.isfinite(state).all():
        raise ProtocolError(ErrorType.NAN, "NaN or infinite values", STATE_KEY)
    out[STATE_KEY] = state.astype(np.float32, copy=False)
    return out


# --------------------------------------------------------------------------- replies


def action_reply(action: np.ndarray, *, step: int, inference_ms: float) -> dict[str, Any]:
    """``{"ok": true, "action": float32 (A,) or (K, A), "step": n, "inference_ms": t}``."""
    return {"ok": True, "action": np.asarray(action, dtype=np.float32), "step": step, "inference_ms": inference_ms}


def info_reply(spec: PolicySpec) -> dict[str, Any]:
    """``{"ok": true, "protocol": 1, "policy": {...}}``."""
    return {"ok": True, "protocol": PROTOCOL_VERSION, "policy": spec.as_dict()}


def error_reply(error: ProtocolError) -> dict[str, Any]:
    """``{"ok": false, "error": {"type": ..., "message": ..., "field": ... or null}}``."""
    return {"ok": False, "error": {"type": error.type.value, "message": str(error), "field": error.field}}
