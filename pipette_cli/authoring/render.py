"""Task plan -> registry YAML through the jinja2 template ``templates/tasks/_draft.yaml.j2``.

The template writes every value; comments mark the fields a person must verify. Values are
formatted by the filters below (YAML flow style, safe quoting), never by the LLM.
"""

from __future__ import annotations

import json
import re
from functools import cache
from typing import Any

import jinja2

from pipette_cli.authoring.compose import TaskPlan
from pipette_cli.resources import data_dir

DRAFT_TEMPLATE = "tasks/_draft.yaml.j2"
_PLAIN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9 _./()%+-]*$")


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
    if _PLAIN.match(text) and not text.lower() in ("yes", "no", "true", "false", "null", "on", "off") and not re.fullmatch(r"[\d.eE+-]+", text):
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
    return " " * indent + "- " + block.lstrip("\n")[indent + 2:]


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


def render_plan(plan: TaskPlan, *, description: str, backend: str) -> str:
    """The registry YAML of ``plan``."""
    context = {k: getattr(plan, k) for k in (
        "task_id", "name", "category", "tags", "instruction", "robot", "initial_joints", "objects",
        "joint_states", "mechanisms", "targets", "success", "comments", "notes", "cameras", "family")}
    one_line = " ".join(description.split())
    return environment().get_template(DRAFT_TEMPLATE).render(description=one_line, backend=backend, **context)
