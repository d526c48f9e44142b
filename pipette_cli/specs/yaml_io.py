"""Task YAML in and out: comment-preserving round trips and errors that name file:line.

ruamel.yaml keeps comments and layout, so a person's edits to a registry file survive a
load/dump cycle. Every problem is reported as ``file:line: field.path: message``.
"""

from __future__ import annotations

import io
import types
import typing
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq
from ruamel.yaml.error import MarkedYAMLError, YAMLError

from pipette_cli.errors import SpecError, suggest
from pipette_cli.specs.base import REGISTRIES

Loc = tuple[str | int, ...]


def make_yaml() -> YAML:
    """The round-trip YAML object with the registry's house style."""
    yaml = YAML(typ="rt")
    yaml.indent(mapping=2, sequence=4, offset=2)
    yaml.width = 100
    yaml.preserve_quotes = True
    return yaml


def read_yaml(path: Path) -> Any:
    """Parse ``path`` keeping comments and line numbers.

    Raises:
        SpecError: ``file:line: message`` on unreadable files, syntax errors or non-mapping tops.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SpecError(f"{path}: cannot read: {exc.strerror or exc}") from None
    return parse_yaml(text, str(path))


def parse_yaml(text: str, source: str = "<string>") -> Any:
    """Parse YAML text; see :func:`read_yaml`."""
    try:
        data = make_yaml().load(text)
    except MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f":{mark.line + 1}" if mark is not None else ""
        context = exc.context or ""
        if context and exc.context_mark is not None and exc.context_mark is not mark:
            context += f" (from line {exc.context_mark.line + 1})"
        what = ": ".join(p for p in (context, exc.problem) if p)
        raise SpecError(f"{source}{line}: YAML syntax error: {what}") from None
    except YAMLError as exc:
        raise SpecError(f"{source}: YAML error: {exc}") from None
    if not isinstance(data, CommentedMap):
        raise SpecError(f"{source}:1: expected a mapping of task fields at the top level, got {type(data).__name__}")
    return data


def dump_yaml(data: Any) -> str:
    """Serialise plain data or a ruamel document in the house style."""
    buffer = io.StringIO()
    make_yaml().dump(data, buffer)
    return buffer.getvalue()


def to_plain(node: Any) -> Any:
    """Recursively turn ruamel containers into dicts and lists."""
    if isinstance(node, dict):
        return {str(k): to_plain(v) for k, v in node.items()}
    if isinstance(node, list):
        return [to_plain(v) for v in node]
    return node


def line_of(doc: Any, loc: Iterable[str | int]) -> int:
    """1-based line of the deepest node of ``loc`` present in ``doc`` (1 when none is)."""
    line = 0
    node = doc
    for part in loc:
        if isinstance(node, CommentedMap) and part in node:
            line = node.lc.key(part)[0]
            node = node[part]
        elif isinstance(node, CommentedSeq) and isinstance(part, int) and 0 <= part < len(node):
            line = node.lc.item(part)[0]
            node = node[part]
        # otherwise the segment is a union tag or a missing key: stay on the parent
    return line + 1


def dotted(loc: Loc) -> str:
    return ".".join(str(p) for p in loc) or "<top>"


def format_problem(source: str, doc: Any, loc: Loc, message: str) -> str:
    return f"{source}:{line_of(doc, loc)}: {dotted(loc)}: {message}"


def _unwrap(annotation: Any) -> type | None:
    """Strip Annotated / Optional / list wrappers down to a class, if there is one."""
    while True:
        origin = typing.get_origin(annotation)
        if origin is typing.Annotated:
            annotation = typing.get_args(annotation)[0]
        elif origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(annotation) if a is not type(None)]
            if len(args) != 1:
                return None
            annotation = args[0]
        elif origin in (list, tuple):
            annotation = typing.get_args(annotation)[0]
        else:
            return annotation if isinstance(annotation, type) else None


def _dispatch(cls: type | None, node: Any) -> type | None:
    """Follow ``type:`` (or the registry's key) to the registered class when ``cls`` is a pluggable base."""
    for registry in REGISTRIES:
        if cls is registry.base and isinstance(node, dict) and node.get(registry.key) in registry:
            return registry.get(node[registry.key])
    return cls


def _allowed_keys(model: type[BaseModel], loc: Loc, raw: Any) -> list[str] | None:
    """Field names of the model found at ``loc`` in ``raw`` (following ``type:``), or None."""
    current: type | None = model
    node = raw
    for part in loc:
        if isinstance(part, str):
            if not (isinstance(current, type) and issubclass(current, BaseModel)) or part not in current.model_fields:
                return None
            current = _unwrap(current.model_fields[part].annotation)
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            node = None
        current = _dispatch(current, node)
    if isinstance(current, type) and issubclass(current, BaseModel):
        return list(current.model_fields)
    return None


def validation_problems(exc: ValidationError, model: type[BaseModel], raw: Any, doc: Any, source: str) -> list[str]:
    """One ``file:line: field: message`` line per pydantic error, with hints for unknown keys."""
    problems = []
    for err in exc.errors(include_url=False):
        loc: Loc = tuple(err["loc"])
        message = err["msg"]
        if err["type"] == "extra_forbidden":
            allowed = _allowed_keys(model, loc[:-1], raw)
            key = str(loc[-1])
            hint = suggest(key, allowed) if allowed else ""
            message = f"unknown key {key!r}" + (f"; {hint}" if hint else "")
        elif err["type"] == "missing":
            message = "required field is missing"
        elif err["type"].startswith("literal_error") or err["type"] == "literal_error":
            message = f"{message} (got {err.get('input')!r})"
        elif err["type"] == "spec_type" and isinstance(err.get("input"), dict):
            type_key = next((r.key for r in REGISTRIES if r.key in err["input"]), None)
            loc = (*loc, type_key) if type_key else loc
        elif err["type"] == "value_error":
            message = message.removeprefix("Value error, ")
        problems.append(format_problem(source, doc, loc, message))
    return problems


M = typing.TypeVar("M", bound=BaseModel)


def read_spec(path: Path, model: type[M]) -> M:
    """The YAML file at ``path`` validated as ``model``.

    Raises:
        SpecError: ``file:line: field: message`` for each problem (or the file's YAML error).
    """
    doc = read_yaml(path)
    raw = to_plain(doc)
    try:
        return model.model_validate(raw)
    except ValidationError as exc:
        raise SpecError(validation_problems(exc, model, raw, doc, str(path))) from None
