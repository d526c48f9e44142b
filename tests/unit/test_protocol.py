"""The policy-server wire format: msgpack + raw numpy buffers, request schema, observation checks."""

from __future__ import annotations

import pickle

import msgpack
import numpy as np
import pytest

from pipette_cli.serving.protocol import (
    ActRequest,
    ErrorType,
    InfoRequest,
    PolicySpec,
    ProtocolError,
    check_observation,
    pack,
    parse_request,
    unpack,
)

SPEC = PolicySpec(
    policy_type="act",
    images={"observation.images.top": (3, 4, 4), "observation.images.wrist": (3, 4, 4)},
    state_shape=(8,),
    action_dim=8,
    chunk_size=5,
)


def _obs(**over) -> dict:
    obs = {
        "observation.images.top": np.zeros((3, 4, 4), np.uint8),
        "observation.images.wrist": np.full((3, 4, 4), 0.5, np.float32),
        "observation.state": np.arange(8, dtype=np.float32),
        "task": "close the lid",
    }
    obs.update(over)
    return {k: v for k, v in obs.items() if v is not None}


def _error(fn, *args) -> ProtocolError:
    with pytest.raises(ProtocolError) as info:
        fn(*args)
    return info.value


@pytest.mark.parametrize("dtype", [np.uint8, np.float32, np.float64])
def test_arrays_round_trip_bit_exact(dtype) -> None:
    arr = (np.random.default_rng(0).random((3, 5, 7)) * 200).astype(dtype)
    back = unpack(pack({"a": arr, "nested": [arr[0]], "n": np.float32(2.5)}))
    assert back["a"].dtype == dtype and back["a"].shape == (3, 5, 7) and np.array_equal(back["a"], arr)
    assert np.array_equal(back["nested"][0], arr[0]) and back["n"] == 2.5


def test_non_contiguous_arrays_are_sent_in_order() -> None:
    arr = np.arange(24, dtype=np.float32).reshape(2, 3, 4).transpose(2, 0, 1)
    assert np.array_equal(unpack(pack({"a": arr}))["a"], arr)


def test_pack_refuses_object_arrays_and_arbitrary_objects() -> None:
    with pytest.raises(TypeError):
        pack({"a": np.array([object()])})
    with pytest.raises(TypeError):
        pack({"a": {1, 2}})


def test_a_pickle_payload_is_refused_and_never_run(tmp_path) -> None:
    marker = tmp_path / "pwned"

    class Evil:
        def __reduce__(self):
            return (marker.write_text, ("ran",))

    err = _error(unpack, pickle.dumps(Evil()))
    assert err.type is ErrorType.BAD_REQUEST and not marker.exists()


@pytest.mark.parametrize(
    ("array_map", "expected"),
    [
        ({"__ndarray__": True, "dtype": "|O", "shape": [1], "data": b"\0" * 8}, ErrorType.BAD_DTYPE),
        ({"__ndarray__": True, "dtype": ">f4", "shape": [1], "data": b"\0" * 4}, ErrorType.BAD_DTYPE),
        ({"__ndarray__": True, "dtype": "<f4", "shape": [3], "data": b"\0" * 4}, ErrorType.BAD_SHAPE),
        ({"__ndarray__": True, "dtype": "<f4", "shape": [-1], "data": b"\0" * 4}, ErrorType.BAD_REQUEST),
        ({"__ndarray__": True, "dtype": "<f4", "shape": [1, 1, 1, 1, 1], "data": b"\0" * 4}, ErrorType.BAD_REQUEST),
        ({"__ndarray__": True, "dtype": "<f4", "shape": [1], "data": "abcd"}, ErrorType.BAD_REQUEST),
        ({"__ndarray__": True, "dtype": "<f4", "shape": [1], "data": b"\0" * 4, "x": 1}, ErrorType.BAD_REQUEST),
    ],
)
def test_bad_array_maps_are_typed_errors(array_map, expected) -> None:
    assert _error(unpack, msgpack.packb({"observation.state": array_map})).type is expected


@pytest.mark.parametrize(
    "payload", [b"", b"\xc1", b"\x92\x01", msgpack.packb({"a": 1})[:-1], msgpack.packb({1: 2}), b"\xff" * 50]
)
def test_garbage_is_bad_request(payload) -> None:
    with pytest.raises(ProtocolError) as info:
        parse_request(unpack(payload))
    assert info.value.type is ErrorType.BAD_REQUEST


def test_oversized_requests_are_refused_before_decoding() -> None:
    err = _error(lambda: unpack(pack({"x": np.zeros(1000, np.uint8)}), max_bytes=500))
    assert err.type is ErrorType.TOO_LARGE and "500" in str(err)


def test_request_schema() -> None:
    req = parse_request(unpack(pack(_obs(reset_policy=True))))
    assert isinstance(req, ActRequest) and req.reset_policy and req.task == "close the lid" and not req.chunk
    assert set(req.images()) == {"observation.images.top", "observation.images.wrist"}
    assert parse_request({**_obs(task=None), "language_instruction": "open it"}).task == "open it"
    assert isinstance(parse_request({"command": "info"}), InfoRequest)
    for bad, field in [
        (_obs(extra=1), "extra"),
        (_obs(task=3), "task"),
        (_obs(reset_policy=1), "reset_policy"),
        (_obs(**{"observation.state": [0.0] * 8}), "observation.state"),
        ({"command": "shutdown"}, "command"),
        ({"command": "info", "x": 1}, "x"),
    ]:
        err = _error(parse_request, bad)
        assert err.type is ErrorType.BAD_REQUEST and err.field == field, (bad, err)
    assert _error(parse_request, [1, 2]).type is ErrorType.BAD_REQUEST


def test_observation_checks_against_the_policy() -> None:
    extra_camera = np.zeros((3, 9, 9), np.uint8)  # a camera the policy does not read is ignored
    checked = check_observation(
        parse_request(_obs(**{"observation.images.main": extra_camera, "observation.state": np.zeros(8)})), SPEC
    )
    assert set(checked) == {"observation.images.top", "observation.images.wrist", "observation.state"}
    assert checked["observation.state"].dtype == np.float32

    nan_state = np.zeros(8, np.float32)
    nan_state[3] = np.nan
    hot = np.full((3, 4, 4), 1.5, np.float32)
    inf_img = np.zeros((3, 4, 4), np.float32)
    inf_img[0, 0, 0] = np.inf
    cases = [
        (_obs(**{"observation.images.top": None}), ErrorType.BAD_REQUEST, "observation.images.top"),
        (
            _obs(**{"observation.images.top": np.zeros((4, 4, 3), np.uint8)}),
            ErrorType.BAD_SHAPE,
            "observation.images.top",
        ),
        (_obs(**{"observation.images.top": np.zeros((3, 4, 4))}), ErrorType.BAD_DTYPE, "observation.images.top"),
        (_obs(**{"observation.images.wrist": hot}), ErrorType.OUT_OF_RANGE, "observation.images.wrist"),
        (_obs(**{"observation.images.wrist": inf_img}), ErrorType.NAN, "observation.images.wrist"),
        (_obs(**{"observation.state": np.zeros(7, np.float32)}), ErrorType.BAD_SHAPE, "observation.state"),
        (_obs(**{"observation.state": np.zeros(8, np.uint8)}), ErrorType.BAD_DTYPE, "observation.state"),
        (_obs(**{"observation.state": nan_state}), ErrorType.NAN, "observation.state"),
    ]
    for obs, kind, field in cases:
        err = _error(check_observation, parse_request(unpack(pack(obs))), SPEC)
        assert (err.type, err.field) == (kind, field), (field, err)
