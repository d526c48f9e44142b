"""``pipette serve``: answer a LeRobot policy's actions over ZeroMQ (paper A.4, docs/serving.md)."""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Annotated

import typer

from pipette_cli.cli.common import STATE, err_console, out_console, policy_folder_of, print_json
from pipette_cli.errors import plural
from pipette_cli.serving.protocol import DEFAULT_DEVICE, DEFAULT_ENDPOINT, DEFAULT_MAX_REQUEST_BYTES


def serve(
    policy: Annotated[
        Path,
        typer.Option(
            "--policy",
            help="LeRobot policy folder (config.json, model.safetensors, processor files), or a training run "
            "folder (its last checkpoint).",
        ),
    ],
    bind: Annotated[
        str, typer.Option("--bind", help="ZeroMQ endpoint (paper A.4); port 0 lets the OS pick one.")
    ] = DEFAULT_ENDPOINT,
    allow_remote: Annotated[
        bool, typer.Option("--allow-remote", help="Allow a non-loopback address (the server has no authentication).")
    ] = False,
    device: Annotated[
        str, typer.Option("--device", help="auto (cuda when available), cpu or cuda[:N].")
    ] = DEFAULT_DEVICE,
    max_request_mb: Annotated[
        float, typer.Option("--max-request-mb", min=0.001, help="Larger requests are answered too_large.")
    ] = DEFAULT_MAX_REQUEST_BYTES / 2**20,
    max_requests: Annotated[
        int | None, typer.Option("--max-requests", min=1, help="Stop after this many requests (tests, smoke runs).")
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable start and stop lines.")] = False,
) -> None:
    """Serve a trained policy to evaluation clients (msgpack over a ZeroMQ socket, never pickle).

    Requests carry observation.images.top|main|wrist (CHW uint8, or float32 in [0, 1]),
    observation.state, task and reset_policy; replies carry one action or an action chunk, or a
    typed error (bad_request, bad_shape, bad_dtype, nan, out_of_range, too_large, internal)
    after which the server keeps serving. Stop it with Ctrl-C.

    Example: pipette serve --policy outputs/train/act/pipette_PickUpTestTube-v1_raw
    """
    from pipette_cli.serving.server import LeRobotRunner, PolicyServer, check_endpoint  # deferred: zmq (~15 ms)

    check_endpoint(bind, allow_remote=allow_remote)  # before the slow policy load
    policy = policy_folder_of(policy)
    runner = LeRobotRunner(policy, device=device)
    server = PolicyServer(runner, bind, allow_remote=allow_remote, max_request_bytes=int(max_request_mb * 2**20))
    spec = runner.spec
    if as_json:
        print_json({"event": "ready", "endpoint": server.endpoint, "device": runner.device, "policy": spec.as_dict()})
    else:
        out_console.print(
            f"serving {spec.policy_type} from {policy} on {server.endpoint} ({runner.device}; cameras "
            f"{', '.join(k.rsplit('.', 1)[-1] for k in spec.images)}; action {spec.action_dim}, chunk {spec.chunk_size})"
        )
    previous = signal.signal(signal.SIGINT, lambda *_: server.stop())
    try:
        stats = server.serve_forever(
            max_requests=max_requests,
            on_request=None
            if STATE.verbosity < 1
            else lambda s: err_console.print(
                f"request {s.requests}: {plural(s.actions, 'action')}, {plural(s.errors, 'error')}"
            ),
        )
    finally:
        signal.signal(signal.SIGINT, previous)
    mean_ms = 1000 * stats.inference_s / stats.actions if stats.actions else 0.0
    if as_json:
        print_json(
            {
                "event": "stopped",
                "requests": stats.requests,
                "actions": stats.actions,
                "errors": stats.errors,
                "mean_inference_ms": round(mean_ms, 3),
            }
        )
    else:
        out_console.print(
            f"stopped after {plural(stats.requests, 'request')} ({plural(stats.actions, 'action')}, "
            f"{plural(stats.errors, 'error')}, "
            f"{mean_ms:.1f} ms mean inference)"
        )
