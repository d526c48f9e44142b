"""LLM backends over real HTTP against a fake OpenAI-compatible / Ollama server on 127.0.0.1.

The server answers from a script (one entry per request) and records every request, so the
tests see what the backend sent: the JSON schema, and the validation errors it re-asks with.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from pipette_cli.authoring.assets_new import draft_asset
from pipette_cli.authoring.backends import make_backend
from pipette_cli.authoring.workflow import draft_task
from pipette_cli.errors import BackendError, PipetteError

GOOD_DRAFT = {
    "objects": [
        {"name": "tube", "asset": "conical_tube_50ml_skirted", "role": "item"},
        {"name": "balance", "asset": "electronic_balance", "role": "destination"},
    ],
    "steps": [{"action": "place", "object": "tube", "target": "balance", "source": None, "part": None}],
    "robot": None,
    "instruction": "Put the tube on the balance.",
    "thresholds": {
        "lift_height_m": None,
        "hold_s": None,
        "timeout_s": None,
        "max_tilt_deg": None,
        "xy_tolerance_m": None,
    },
}


def chat_reply(content: str) -> dict:
    return {"choices": [{"index": 0, "message": {"role": "assistant", "content": content}}]}


class FakeServer:
    """Scripted replies: (status, body dict or raw str, delay seconds)."""

    def __init__(self) -> None:
        self.script: list[tuple[int, object, float]] = []
        self.requests: list[dict] = []
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:
                body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                fake.requests.append({"path": self.path, "body": body, "auth": self.headers.get("Authorization")})
                status, reply, delay = fake.script.pop(0) if fake.script else (500, "script exhausted", 0.0)
                if delay:
                    time.sleep(delay)
                data = reply.encode() if isinstance(reply, str) else json.dumps(reply).encode()
                try:
                    self.send_response(status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client timed out and left

            def log_message(self, *args) -> None:
                pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def server() -> Iterator[FakeServer]:
    fake = FakeServer()
    yield fake
    fake.close()


def openai(server: FakeServer, **kw):
    options = {
        "base_url": server.url + "/v1",
        "model": "test-model",
        "api_key": "sk-test",
        "timeout_s": 2.0,
        "max_attempts": 3,
    }
    options.update(kw)
    return make_backend("openai", **options)


def test_valid_structured_reply_becomes_a_built_task(server) -> None:
    server.script = [(200, chat_reply(json.dumps(GOOD_DRAFT)), 0.0)]
    drafted = draft_task("Put the tube on the balance", openai(server))
    assert drafted.spec.success.type == "region_hold" and drafted.backend == "openai"
    assert drafted.spec.object("tube").asset == "conical_tube_50ml_skirted"
    request = server.requests[0]
    assert request["path"] == "/v1/chat/completions" and request["auth"] == "Bearer sk-test"
    fmt = request["body"]["response_format"]
    assert fmt["type"] == "json_schema" and fmt["json_schema"]["name"] == "TaskPlanSpec"
    schema = fmt["json_schema"]["schema"]
    assert schema["additionalProperties"] is False and set(schema["required"]) == set(schema["properties"])
    assert "conical_tube_50ml_skirted" in schema["$defs"]["PlanObjectSpec"]["properties"]["asset"]["enum"]
    system = request["body"]["messages"][0]["content"]
    assert "conical_tube_50ml_skirted" in system and "electronic_balance" in system  # the vocabulary is in the prompt
    assert len(system) < 6000  # with the schema, well inside a 4k-token context


def test_malformed_json_is_reasked_with_the_parse_error(server) -> None:
    server.script = [
        (200, chat_reply('{"steps": [{"action": "place", "objects": [ oops'), 0.0),
        (200, chat_reply("```json\n" + json.dumps(GOOD_DRAFT) + "\n```"), 0.0),
    ]
    drafted = draft_task("Put the tube on the balance", openai(server))
    assert drafted.spec.id == "generated/PlaceConicalTubeOnBalance-v1"  # ids stay within 48 characters
    second = server.requests[1]["body"]["messages"]
    assert second[-2]["role"] == "assistant" and "oops" in second[-2]["content"]
    assert "not valid JSON" in second[-1]["content"]


def test_schema_violation_is_reasked_with_the_field_errors(server) -> None:
    bad = dict(
        GOOD_DRAFT,
        steps=[dict(GOOD_DRAFT["steps"][0], action="juggle")],
        thresholds=dict(GOOD_DRAFT["thresholds"], timeout_s=-3),
    )
    server.script = [(200, chat_reply(json.dumps(bad)), 0.0), (200, chat_reply(json.dumps(GOOD_DRAFT)), 0.0)]
    draft_task("Put the tube on the balance", openai(server))
    reask = server.requests[1]["body"]["messages"][-1]["content"]
    assert "steps.0.action" in reask and "thresholds.timeout_s" in reask


def test_a_step_naming_a_missing_object_is_reasked_with_the_names(server) -> None:
    bad = dict(GOOD_DRAFT, steps=[dict(GOOD_DRAFT["steps"][0], target="scale")])
    server.script = [(200, chat_reply(json.dumps(bad)), 0.0), (200, chat_reply(json.dumps(GOOD_DRAFT)), 0.0)]
    draft_task("Put the tube on the balance", openai(server))
    reask = server.requests[1]["body"]["messages"][-1]["content"]
    assert "steps.0.target: 'scale' is not one of the objects (tube, balance)" in reask


def test_an_object_the_description_does_not_name_is_reasked(server) -> None:
    bad = json.loads(json.dumps(GOOD_DRAFT))
    bad["objects"][1]["asset"] = "orbital_shaker"
    server.script = [(200, chat_reply(json.dumps(bad)), 0.0), (200, chat_reply(json.dumps(GOOD_DRAFT)), 0.0)]
    draft_task("Put the tube on the balance", openai(server))
    reask = server.requests[1]["body"]["messages"][-1]["content"]
    assert "the description names no shaker" in reask


def test_an_impossible_plan_is_reasked_with_the_robot_limit(server) -> None:
    bad = json.loads(json.dumps(GOOD_DRAFT))
    bad["objects"][0]["asset"] = "beaker_1000ml"
    server.script = [(200, chat_reply(json.dumps(bad)), 0.0), (200, chat_reply(json.dumps(GOOD_DRAFT)), 0.0)]
    draft_task("Put the tube on the balance", openai(server))
    reask = server.requests[1]["body"]["messages"][-1]["content"]
    assert "gripper opens 80 mm" in reask


def test_liquids_are_refused_before_any_request(server) -> None:
    with pytest.raises(PipetteError, match="liquids are not simulated"):
        draft_task("Pour the buffer into the beaker", openai(server))
    assert server.requests == []


def test_unknown_asset_is_reasked_with_a_suggestion(server) -> None:
    bad = json.loads(json.dumps(GOOD_DRAFT))
    bad["objects"][1]["asset"] = "flux capacitor"
    server.script = [(200, chat_reply(json.dumps(bad)), 0.0), (200, chat_reply(json.dumps(GOOD_DRAFT)), 0.0)]
    draft_task("Put the tube on the balance", openai(server))
    reask = server.requests[1]["body"]["messages"][-1]["content"]
    assert "objects.1.asset: unknown object 'flux capacitor'; nearest:" in reask


def test_timeout_is_retried_then_succeeds(server) -> None:
    server.script = [(200, chat_reply(json.dumps(GOOD_DRAFT)), 1.0), (200, chat_reply(json.dumps(GOOD_DRAFT)), 0.0)]
    backend = openai(server, timeout_s=0.3)
    start = time.perf_counter()
    draft_task("Put the tube on the balance", backend)
    assert backend.attempts_used == 2 and time.perf_counter() - start < 5


def test_every_attempt_failing_raises_backend_error_with_the_reasons(server) -> None:
    server.script = [(200, chat_reply("not json"), 0.0), (500, "boom", 0.0), (200, {"no": "choices"}, 0.0)]
    with pytest.raises(BackendError) as info:
        draft_task("Put the tube on the balance", openai(server))
    text = " ".join(info.value.problems)
    assert "no valid answer after 3 attempt(s)" in text and "no choices[0].message" in text
    assert len(server.requests) == 3  # bounded


def test_auth_error_is_final_and_says_what_to_check(server) -> None:
    server.script = [(401, {"error": "invalid key"}, 0.0)]
    with pytest.raises(BackendError, match="HTTP 401 \\(check the API key\\)"):
        draft_task("Put the tube on the balance", openai(server))
    assert len(server.requests) == 1


def test_unreachable_server_fails_cleanly() -> None:
    backend = make_backend("openai", base_url="http://127.0.0.1:9/v1", model="m", timeout_s=0.5, max_attempts=2)
    with pytest.raises(BackendError, match="cannot reach the server"):
        draft_task("Put the tube on the balance", backend)


def test_configuration_from_the_environment(server, monkeypatch) -> None:
    monkeypatch.setenv("PIPETTE_LLM_BASE_URL", server.url + "/v1")
    monkeypatch.setenv("PIPETTE_LLM_MODEL", "env-model")
    monkeypatch.setenv("PIPETTE_LLM_API_KEY", "sk-env")
    monkeypatch.setenv("PIPETTE_LLM_MAX_ATTEMPTS", "1")
    server.script = [(200, chat_reply(json.dumps(GOOD_DRAFT)), 0.0)]
    draft_task("Put the tube on the balance", make_backend("openai"))
    assert server.requests[0]["body"]["model"] == "env-model" and server.requests[0]["auth"] == "Bearer sk-env"


def test_ollama_native_chat_with_format_schema(server) -> None:
    server.script = [(200, {"message": {"role": "assistant", "content": json.dumps(GOOD_DRAFT)}, "done": True}, 0.0)]
    backend = make_backend("ollama", base_url=server.url, model="qwen-test", timeout_s=2.0, max_attempts=1)
    drafted = draft_task("Put the tube on the balance", backend)
    body = server.requests[0]["body"]
    assert server.requests[0]["path"] == "/api/chat" and body["stream"] is False
    assert (
        body["format"]["$defs"]["PlanStepSpec"]["properties"]["action"]["enum"][0] == "pick"
        and drafted.backend == "ollama"
    )


def test_asset_generation_through_the_llm_backend(server) -> None:
    server.script = [
        (
            200,
            chat_reply(json.dumps({"generator": "beaker", "volume_ml": 99999, "diameter_mm": None, "length_mm": None})),
            0.0,
        ),
        (
            200,
            chat_reply(json.dumps({"generator": "beaker", "volume_ml": 300, "diameter_mm": None, "length_mm": None})),
            0.0,
        ),
    ]
    drafted = draft_asset("a 300 mL beaker", openai(server))
    assert drafted.asset_id == "beaker_300ml" and drafted.reference == "beaker_250ml"
    assert "volume_ml" in server.requests[1]["body"]["messages"][-1]["content"]
