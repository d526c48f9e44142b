"""Jinja2 environment over the built-in ``templates/`` folder (task YAML, prompts, reports)."""

from __future__ import annotations

from functools import cache

import jinja2

from pipette_cli.errors import PipetteError, suggest
from pipette_cli.resources import data_dir


@cache
def environment() -> jinja2.Environment:
    """A strict environment: undefined variables are errors, not empty strings."""
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(data_dir("templates"))),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        autoescape=False,
    )


def task_template_names() -> list[str]:
    """Public task templates (``templates/tasks/<name>.yaml.j2`` not starting with ``_``)."""
    folder = data_dir("templates") / "tasks"
    return sorted(p.name.removesuffix(".yaml.j2") for p in folder.glob("*.yaml.j2") if not p.name.startswith("_"))


def render_task_template(template: str, **context: object) -> str:
    """Render task template ``template`` with ``context``.

    Raises:
        PipetteError: unknown template, or a variable the template needs is missing.
    """
    names = task_template_names()
    if template not in names:
        raise PipetteError(f"unknown task template {template!r}; {suggest(template, names)}")
    try:
        return environment().get_template(f"tasks/{template}.yaml.j2").render(template=template, **context)
    except jinja2.UndefinedError as exc:
        raise PipetteError(f"task template {template!r}: {exc.message}") from None
