"""The shared structured-output client against imitations of each server kind (httpx.MockTransport).

Each imitation accepts or refuses response formats the way the real server does (the
llama-cpp-python refusal below is the body `python -m llama_cpp.server` 0.3 answers), and
records every request, so the tests see which forms were tried, in which order, how often.
"""

from __future__ import annotations

import json
from collections.abc import Callable

import httpx
import pytest
from pydantic import BaseModel, ConfigDict

from pipette_cli.errors import BackendError, PipetteError
from pipette_cli.llm import FORMS, FormatRejected, ask_structured, extract_json, forget_formats, make_client
from pipette_cli.llm.client import _is_strict

LLAMA_CPP_PYTHON_REFUSAL = {
    "error": {
        "message": "1 validation error:\n  {'type': 'literal_error', 'loc': ('body', 'response_format', 'type'), "
        "'msg': \"Input should be 'text' or 'json_object'\", 'input': 'json_schema'}",
        "type": "internal_server_error",
        "param": None,
        "code": None,
    }
}


class Answer(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    word: str
    count: int


def chat(content: str) -> dict:
    return {"choices": [{"index": 0, "message": {"role": "assistant", "content": content}}]}


class Imitation:
    """A server kind: ``accepts(body) -> None`` or ``(status, body)`` for a refusal."""

    def __init__(
        self,
        accepts: Callable[[dict], tuple[int, object] | None],
        replies: list[str] | None = None,
        ollama: bool = False,
    ) -> None:
        self.accepts = accepts
        self.replies = list(replies or ['{"word": "ok", "count": 1}'])
        self.bodies: list[dict] = []
        self.ollama = ollama

    def __call__(self, request: httpx.Request) -> httpx.Response:
        body = json.loads(request.content)
        self.bodies.append(body)
        refusal = self.accepts(body)
        if refusal is not None:
            status, payload = refusal
            return (
                httpx.Response(status, json=payload)
                if not isinstance(payload, str)
                else httpx.Response(status, text=payload)
            )
        content = self.replies.pop(0) if len(self.replies) > 1 else self.replies[0]
        return httpx.Response(
            200,
            json={"message": {"role": "assistant", "content": content}, "done": True} if self.ollama else chat(content),
        )

    def forms(self) -> list[str]:
        out = []
        for body in self.bodies:
            fmt = body.get("response_format") or {}
            if self.ollama:
                out.append("prompt" if "format" not in body else "json" if body["format"] == "json" else "schema")
            elif not fmt:
                out.append("prompt")
            else:
                out.append(
                    {"json_schema": "json_schema"}.get(
                        fmt["type"], "json_object_schema" if "schema" in fmt else "json_object"
                    )
                )
        return out


def openai_like(body: dict) -> None:
    return None


def llama_cpp_python(body: dict) -> tuple[int, object] | None:
    fmt = body.get("response_format") or {}
    return (500, LLAMA_CPP_PYTHON_REFUSAL) if fmt.get("type") == "json_schema" else None


def json_mode_only(body: dict) -> tuple[int, object] | None:
    fmt = body.get("response_format") or {}
    if fmt.get("type") == "json_schema" or "schema" in fmt:
        return 400, {"error": {"message": "response_format: only {'type': 'json_object'} is supported"}}
    return None


def no_response_format(body: dict) -> tuple[int, object] | None:
    if "response_format" in body:
        return 400, {"error": {"message": "Unrecognized request argument supplied: response_format"}}
    return None


def old_ollama(body: dict) -> tuple[int, object] | None:
    if isinstance(body.get("format"), dict):
        return 400, {"error": "json: cannot unmarshal object into Go struct field ChatRequest.format of type string"}
    return None


def refuses_all(body: dict) -> tuple[int, object]:
    return 422, {"detail": "response_format is not allowed here"}


@pytest.fixture(autouse=True)
def fresh_memory():
    forget_formats()
    yield
    forget_formats()


def client(imitation: Imitation, kind: str = "openai", url: str = "http://llm.test/v1", **kw):
    return make_client(kind, base_url=url, model="m", transport=httpx.MockTransport(imitation), **kw)


def ask(c, accept=lambda a: a, trace=None):
    return ask_structured(c, system="Answer.", user="hi", schema=Answer, accept=accept, trace=trace)


@pytest.mark.parametrize(
    ("server", "kind", "tried"),
    [
        (openai_like, "openai", ["json_schema"]),
        (llama_cpp_python, "openai", ["json_schema", "json_object_schema"]),
        (json_mode_only, "openai", ["json_schema", "json_object_schema", "json_object"]),
        (no_response_format, "openai", ["json_schema", "json_object_schema", "json_object", "prompt"]),
        (openai_like, "ollama", ["schema"]),
        (old_ollama, "ollama", ["schema", "json"]),
    ],
    ids=["openai", "llama-cpp-python", "json-mode-only", "no-response-format", "ollama", "old-ollama"],
)
def test_each_server_kind_gets_the_form_it_accepts(server, kind, tried) -> None:
    imitation = Imitation(server, ollama=kind == "ollama")
    c = client(imitation, kind, url="http://127.0.0.1:11434" if kind == "ollama" else "http://llm.test/v1")
    assert ask(c) == Answer(word="ok", count=1)
    assert imitation.forms() == tried and c.form_used == tried[-1]
    last = imitation.bodies[-1]
    system = last["messages"][0]["content"]
    carries = tried[-1] in ("json_schema", "json_object_schema", "schema")
    assert ('"count"' in system) is not carries  # a form without the schema gets it in the instructions


def test_the_accepted_form_is_remembered_per_base_url() -> None:
    imitation = Imitation(llama_cpp_python)
    ask(client(imitation))
    ask(client(imitation))  # a new client for the same server: no second refusal
    assert imitation.forms() == ["json_schema", "json_object_schema", "json_object_schema"]
    other = Imitation(llama_cpp_python)
    ask(client(other, url="http://other.test/v1"))
    assert other.forms() == ["json_schema", "json_object_schema"]


def test_a_server_refusing_every_form_fails_once_per_form_never_loops() -> None:
    imitation = Imitation(refuses_all)
    with pytest.raises(BackendError, match="HTTP 422"):
        ask(client(imitation, max_attempts=3))
    assert imitation.forms() == list(FORMS["openai"])  # each form once, then a clear error, not 3 x 4 requests
    forced = Imitation(refuses_all)
    with pytest.raises(FormatRejected, match="accepted no structured-output form"):
        ask(client(forced, url="http://forced.test/v1", response_format="json_schema"))
    assert len(forced.bodies) == 1


def test_a_plain_server_error_is_retried_not_taken_for_a_refused_form() -> None:
    calls = []

    def flaky(body: dict) -> tuple[int, object] | None:
        calls.append(1)
        return (500, "upstream overloaded") if len(calls) == 1 else None

    imitation = Imitation(flaky)
    trace: list[str] = []
    assert ask(client(imitation), trace=trace).word == "ok"
    assert imitation.forms() == ["json_schema", "json_schema"] and "HTTP 500" in trace[0]


def test_invalid_answers_are_sent_back_with_the_errors_and_attempts_are_bounded() -> None:
    imitation = Imitation(
        openai_like, replies=['Sure! {"word": "x"}', '{"word": "x", "count": "many"}', "not json at all"]
    )
    trace: list[str] = []
    with pytest.raises(BackendError) as info:
        ask(client(imitation, max_attempts=3), trace=trace)
    assert len(imitation.bodies) == 3 and len(trace) == 3
    second, third = imitation.bodies[1]["messages"], imitation.bodies[2]["messages"]
    assert second[-2] == {"role": "assistant", "content": 'Sure! {"word": "x"}'}
    assert "count: Field required" in second[-1]["content"]
    assert "count: Input should be a valid integer" in third[-1]["content"]
    assert len(third) == 4  # only the last exchange goes back: small contexts stay small
    assert (
        "no valid answer after 3 attempt(s)" in info.value.problems[0] and "not valid JSON" in info.value.problems[-1]
    )


def test_a_rejection_by_accept_is_sent_back_and_a_final_one_is_not() -> None:
    imitation = Imitation(openai_like, replies=['{"word": "bad", "count": 1}', '{"word": "good", "count": 2}'])

    def accept(answer: Answer) -> Answer:
        if answer.word == "bad":
            raise PipetteError("word 'bad' is not allowed; use 'good'")
        return answer

    assert ask(client(imitation), accept=accept).count == 2
    assert "word 'bad' is not allowed" in imitation.bodies[1]["messages"][-1]["content"]

    class Final(PipetteError):
        final = True

    def refuse(answer: Answer) -> Answer:
        raise Final("diffusion is not supported")

    again = Imitation(openai_like)
    with pytest.raises(Final):
        ask(client(again, url="http://again.test/v1"), accept=refuse)
    assert len(again.bodies) == 1


def test_authentication_errors_are_final() -> None:
    imitation = Imitation(lambda body: (401, {"error": "invalid api key"}))
    with pytest.raises(BackendError, match=r"HTTP 401 \(check the API key\)"):
        ask(client(imitation))
    assert len(imitation.bodies) == 1


def test_a_forced_form_is_the_only_one_tried() -> None:
    imitation = Imitation(llama_cpp_python)
    ask(client(imitation, response_format="json_object_schema"))
    assert imitation.forms() == ["json_object_schema"]
    with pytest.raises(BackendError, match="not one of"):
        make_client("openai", response_format="grammar")


def test_json_is_found_in_fences_and_prose() -> None:
    assert extract_json('```json\n{"a": 1}\n```') == {"a": 1}
    assert extract_json('Here you go: {"a": {"b": [1, 2]}} hope it helps {') == {"a": {"b": [1, 2]}}
    with pytest.raises(json.JSONDecodeError):
        extract_json("no json")


def test_strict_mode_only_for_closed_schemas() -> None:
    closed = {
        "type": "object",
        "properties": {"a": {"type": "string"}},
        "required": ["a"],
        "additionalProperties": False,
    }
    assert _is_strict(closed)
    assert not _is_strict({**closed, "additionalProperties": {"type": "string"}})
    assert not _is_strict({**closed, "required": []})
