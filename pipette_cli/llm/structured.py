"""Ask for a pydantic model, validate the answer, and re-ask with the errors (bounded).

Every failure is turned into feedback the model can act on: a reply that is not JSON, JSON
that does not match the schema (field paths and messages), or a value the caller's ``accept``
rejects (its :class:`~pipette_cli.errors.PipetteError` problems). Only the last exchange is sent
back, so the conversation stays small enough for a 4k-token context. An ``accept`` error with
``final = True`` (e.g. "diffusion is not supported") ends the loop at once: asking again
cannot fix it.
"""

from __future__ import annotations

import json
import logging
import re
import time
from collections.abc import Callable
from typing import Any, TypeVar

import httpx
from pydantic import BaseModel, ValidationError

from pipette_cli.errors import BackendError, PipetteError
from pipette_cli.llm.client import ChatClient, Retryable

log = logging.getLogger(__name__)

T = TypeVar("T")
M = TypeVar("M", bound=BaseModel)
MAX_ECHO = 2000
"""Characters of a rejected reply sent back with the feedback."""


def strict_json_schema(model: type[BaseModel]) -> dict[str, Any]:
    """The model's JSON schema in the subset strict structured output accepts.

    Every property is listed as required (optional ones are nullable), objects forbid extra
    keys, and ``default``/``title`` keywords are dropped.
    """

    def walk(node: Any) -> Any:
        if isinstance(node, dict):
            out = {k: walk(v) for k, v in node.items() if k not in ("default", "title")}
            if out.get("type") == "object" and "properties" in out:
                out["required"] = list(out["properties"])
                out["additionalProperties"] = False
            return out
        if isinstance(node, list):
            return [walk(v) for v in node]
        return node

    return walk(model.model_json_schema())


def extract_json(text: str) -> Any:
    """The JSON value in a reply: the whole text, a Markdown fence's content, or the first
    balanced ``{...}`` (small models add prose around it).

    Raises:
        json.JSONDecodeError: none of these parses.
    """
    fenced = re.search(r"```(?:json)?\s*(.*?)```", text, flags=re.S)
    candidate = fenced.group(1).strip() if fenced else text.strip()
    try:
        return json.loads(candidate)
    except json.JSONDecodeError as first:
        decoder = json.JSONDecoder()
        for match in re.finditer(r"\{", candidate):
            try:
                return decoder.raw_decode(candidate, match.start())[0]
            except json.JSONDecodeError:
                continue
        raise first


def backend_error(lines: list[str]) -> BackendError:
    """A :class:`BackendError` whose ``problems`` the CLI prints one per line."""
    exc = BackendError("; ".join(lines))
    exc.problems = list(lines)  # type: ignore[attr-defined]
    return exc


def _problems(exc: PipetteError) -> list[str]:
    return list(getattr(exc, "problems", None) or [str(exc)])


def ask_structured(
    client: ChatClient,
    *,
    system: str,
    user: str,
    schema: type[M],
    accept: Callable[[M], T],
    json_schema: dict[str, Any] | None = None,
    fix_hint: str = "Fix it",
    trace: list[str] | None = None,
) -> T:
    """Ask ``client`` for a ``schema`` instance and return ``accept(instance)``.

    Args:
        client: The server to ask; ``client.spec.max_attempts`` bounds the requests.
        system: Instructions (kept short: small local models have 4k-token contexts).
        user: The request.
        schema: The pydantic model the reply must validate as.
        accept: Checks the instance and finishes the work; raises PipetteError to reject it.
        json_schema: The schema sent to the server (default: :func:`strict_json_schema` of
            ``schema``); callers narrow it, e.g. with an enum of valid names.
        fix_hint: What the feedback after a rejection asks for ("Fix it (use only ...)").
        trace: If given, one line per attempt is appended (what happened).

    Raises:
        BackendError: no acceptable answer within the attempts (``problems`` lists why),
            or a final error of the server (authentication, no structured-output form).
        PipetteError: ``accept`` raised an error marked ``final``.
    """
    sent_schema = json_schema or strict_json_schema(schema)
    base = [{"role": "system", "content": system}, {"role": "user", "content": user}]
    messages = base
    trace = trace if trace is not None else []
    attempts = client.spec.max_attempts
    for attempt in range(1, attempts + 1):
        try:
            content = client.chat(messages, schema_name=schema.__name__, schema=sent_schema)
        except httpx.TimeoutException:
            trace.append(f"attempt {attempt}: no answer within {client.spec.timeout_s:g} s (timeout)")
            log.warning("LLM: %s", trace[-1])
            continue
        except httpx.TransportError as exc:
            trace.append(f"attempt {attempt}: cannot reach the server: {exc}")
            log.warning("LLM: %s", trace[-1])
            time.sleep(min(0.2 * attempt, 1.0))
            continue
        except Retryable as exc:
            trace.append(f"attempt {attempt}: {exc}")
            log.warning("LLM: %s", trace[-1])
            continue
        feedback: str
        try:
            instance = schema.model_validate(extract_json(content))
        except json.JSONDecodeError as exc:
            trace.append(f"attempt {attempt}: the reply is not valid JSON ({exc.msg} at character {exc.pos})")
            feedback = (
                f"Your reply was not valid JSON: {exc.msg} at character {exc.pos}. "
                "Reply with one JSON object matching the schema, nothing else."
            )
        except ValidationError as exc:
            errors = [f"{'.'.join(map(str, e['loc'])) or '<top>'}: {e['msg']}" for e in exc.errors(include_url=False)]
            trace.append(f"attempt {attempt}: the reply does not match the schema: {'; '.join(errors[:8])}")
            feedback = (
                "Your JSON does not match the schema:\n- "
                + "\n- ".join(errors[:12])
                + "\nFix these fields and reply with the whole corrected JSON object."
            )
        else:
            try:
                result = accept(instance)
            except PipetteError as exc:
                if getattr(exc, "final", False):
                    trace.append(f"attempt {attempt}: {exc}")
                    raise
                problems = _problems(exc)
                trace.append(f"attempt {attempt}: rejected: {'; '.join(problems[:6])}")
                feedback = (
                    "This answer cannot be used:\n- "
                    + "\n- ".join(problems[:12])
                    + f"\n{fix_hint} and reply with the whole corrected JSON object."
                )
            else:
                trace.append(f"attempt {attempt}: accepted ({client.form_used})")
                return result
        log.info("LLM: %s", trace[-1])
        messages = [*base, {"role": "assistant", "content": content[:MAX_ECHO]}, {"role": "user", "content": feedback}]
    spec = client.spec
    raise backend_error([f"{spec.kind} backend ({spec.model}): no valid answer after {attempts} attempt(s)", *trace])
