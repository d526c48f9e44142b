"""Composed task -> registry YAML through the jinja2 template ``templates/tasks/_draft.yaml.j2``.

The template writes every value; comments mark the fields a person must verify. Typed specs (the
criterion, the skill steps, mechanisms) are turned into plain mappings here without their default
values, so the YAML reads like a hand-written registry file; values are formatted by the filters
below (YAML flow style, safe quoting), never by an LLM.
"""

from __future__ import annotations

import json
import re
from functools import cache
from typing import Any

import jinja2
from pydantic import BaseModel

from pipette_cli.resources import data_dir
from pipette_cli.taskgen.compose import ComposedTask

DRAFT_TEMPLATE = "tasks/_draft.yaml.j2"
_PLAIN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9 _./()%+-]*$")
KEYS_FIRST = ("type", "skill")
KEYS_LAST = ("hold_s", "timeout_s")


def yaml_scalar(value: Any) -> str:
    """One YAML scalar: numbers as written, strings plain when safe, else double-quoted."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        text = repr(round(value, 6))
        return text if "e" not in text else f"{value:.6f}"
    text = str(value)
    if (
        _PLAIN.match(text)
        and text.lower() not in ("yes", "no", "true", "false", "null", "on", "off")
        and not re.fullmatch(r"[\d.eE+-]+", text)
    ):
        return text
    return json.dumps(text, ensure_ascii=False)


def flow(value: Any) -> str:
    """YAML flow style: ``{pos: [0.5, 0.0, 0.55]}``."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {flow(v)}" for k, v in value.items() if v is not None) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(flow(v) for v in value) + "]"
    return yaml_scalar(value)


def is_leaf(value: Any) -> bool:
    """Short mappings of scalars print inline (``{min: 0.5, max: 0.7}``)."""
    return isinstance(value, dict) and all(not isinstance(v, dict | list) for v in value.values()) and len(value) <= 3


def dash(block: str, indent: int) -> str:
    """Turn the first line's indentation of a rendered mapping into a list item."""
    return " " * indent + "- " + block.lstrip("\n")[indent + 2 :]


def plain(spec: BaseModel) -> dict[str, Any]:
    """A spec as a mapping without null or default values (its ``type``/``skill`` kept), keys in
    reading order: the selector first, hold and timeout last."""
    out: dict[str, Any] = {}
    for name, info in type(spec).model_fields.items():
        value = getattr(spec, name)
        if value is None or (name not in KEYS_FIRST and not info.is_required() and value == info.default):
            continue
        key = info.alias or name
        if isinstance(value, BaseModel):
            out[key] = plain(value)
        elif isinstance(value, dict):
            out[key] = {k: plain(v) if isinstance(v, BaseModel) else v for k, v in value.items()}
        elif isinstance(value, list | tuple):
            out[key] = [plain(v) if isinstance(v, BaseModel) else v for v in value]
        else:
            out[key] = value
    first = {k: out.pop(k) for k in KEYS_FIRST if k in out}
    last = {k: out.pop(k) for k in KEYS_LAST if k in out}
    return {**first, **out, **last}


@cache
def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(data_dir("templates"))),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters.update(flow=flow, scalar=yaml_scalar, dash=dash)
    env.tests["leaf"] = is_leaf
    return env


def render_task(task: ComposedTask, *, description: str, backend: str) -> str:
    """The registry YAML of ``task``."""
    context = {
        "task_id": task.task_id,
        "name": task.name,
        "category": task.category,
        "tags": task.tags,
        "instruction": task.instruction,
        "robot": task.robot,
        "initial_joints": task.initial_joints,
        "objects": task.objects,
        "joint_states": task.joint_states,
        "mechanisms": [plain(m) for m in task.mechanisms],
        "cameras": task.cameras,
        "targets": task.targets,
        "success": plain(task.success),
        "program": [
            (plain(step), stage_index) for stage_index, stage in enumerate(task.stages) for step in stage.program
        ],
        "stages": len(task.stages),
        "comments": task.comments,
        "notes": task.notes,
    }
    one_line = " ".join(description.split())
    return environment().get_template(DRAFT_TEMPLATE).render(description=one_line, backend=backend, **context)
