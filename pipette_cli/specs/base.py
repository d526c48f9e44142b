"""Building blocks shared by all specs: the strict base model, vectors, poses, bounds,
and the small type registry behind every pluggable ``type:`` field."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from typing import Annotated, Any, Generic, TypeVar

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializeAsAny,
    ValidatorFunctionWrapHandler,
    WrapValidator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from pipette_cli.errors import SpecError, suggest
from pipette_cli.plugins import Plugins

NAME_PATTERN = r"^[a-z][a-z0-9_]*$"
Name = Annotated[str, Field(pattern=NAME_PATTERN, description="lower_snake_case name")]
# "object" or "object/part" where part is a body, joint or site inside the object's asset.
Ref = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*(/[A-Za-z0-9_]+)?$", description="object or object/part")]
Vec3 = tuple[float, float, float]
BENCH_TOP_Z = 0.55
"""Height (m) of the bench top in the bench frame (origin on the floor under the robot base, z up): what
the bench asset is built to and the robots stand on by default."""


def described(default: Any, description: str) -> Any:
    """A dataclass field with a default and a description, like a spec's ``Field(default,
    description=...)``: options dataclasses describe their fields this way, and a CLI option bound
    to the field (:func:`pipette_cli.cli.common.spec_help`) shows the description as its help."""
    return dataclasses.field(default=default, metadata={"description": description})


class Spec(BaseModel):
    """Base of every spec: unknown keys are errors, instances are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)


class PoseSpec(Spec):
    """A position in metres and an orientation as XYZ Euler angles in degrees."""

    pos: Vec3
    euler_deg: Vec3 = (0.0, 0.0, 0.0)


class BoundSpec(Spec):
    """A closed interval; either end may be open (``null``)."""

    min: float | None = None
    max: float | None = None

    @model_validator(mode="after")
    def _check(self) -> BoundSpec:
        if self.min is None and self.max is None:
            raise ValueError("give at least one of 'min' and 'max'")
        if self.min is not None and self.max is not None and self.min >= self.max:
            raise ValueError(f"'min' ({self.min}) must be below 'max' ({self.max})")
        return self

    def contains(self, value: float) -> bool:
        return (self.min is None or value >= self.min) and (self.max is None or value <= self.max)


class PluggableSpec(Spec):
    """Base of specs chosen from a :class:`TypeRegistry` by one key (``type:``, ``skill:``)."""

    def refs(self) -> Iterator[tuple[tuple[str | int, ...], str]]:
        """Yield ``(field path, object ref)`` for every scene object this spec names."""
        for name, info in type(self).model_fields.items():
            value = getattr(self, name)
            extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
            if extra.get("ref") and isinstance(value, str):
                yield (name,), value
            elif isinstance(value, PluggableSpec):
                for loc, ref in value.refs():
                    yield (name, *loc), ref
            elif isinstance(value, tuple | list):
                for i, item in enumerate(value):
                    if isinstance(item, PluggableSpec):
                        for loc, ref in item.refs():
                            yield (name, i, *loc), ref


class TypedSpec(PluggableSpec):
    """Base of pluggable specs selected by their ``type`` field."""

    type: str


def ref_field(description: str, default: Any = ...) -> Any:
    """A field holding an ``object`` or ``object/part`` reference, checked against the scene."""
    return Field(default, description=description, json_schema_extra={"ref": True})


T = TypeVar("T", bound=PluggableSpec)
REGISTRIES: list[TypeRegistry[Any]] = []


class TypeRegistry(Generic[T]):
    """Maps ``type`` names to spec classes; adding a type never edits a central list.

    ``key`` is the field that selects the class (``type`` for evaluators and mechanisms, ``skill``
    for expert program steps).
    """

    def __init__(self, kind: str, base: type[T], key: str = "type") -> None:
        self.kind = kind
        self.base = base
        self.key = key
        self._types: Plugins[type[T]] = Plugins(f"{kind} type", SpecError)
        REGISTRIES.append(self)

    def register(self, cls: type[T]) -> type[T]:
        """Class decorator: register ``cls`` under the default of its key field."""
        name = cls.model_fields[self.key].default
        if not isinstance(name, str):
            raise TypeError(f"{cls.__name__} needs a default for its {self.key!r} field")
        return self._types.add(name, cls)

    def name_of(self, cls: type[T]) -> str:
        """The name ``cls`` is registered under (the default of its key field).

        Raises:
            SpecError: ``cls`` is not the class registered under that name.
        """
        field = cls.model_fields.get(self.key)
        name = field.default if field is not None else None
        if not isinstance(name, str) or self._types.find(name) is not cls:
            raise SpecError(f"{cls.__name__} is not a registered {self.kind} type (register it first)")
        return name

    def names(self) -> list[str]:
        return self._types.names()

    def get(self, name: str) -> type[T]:
        return self._types.get(name)

    def __contains__(self, name: object) -> bool:
        return name in self._types

    def validator(self) -> Callable[[Any, ValidatorFunctionWrapHandler], T]:
        def dispatch(value: Any, handler: ValidatorFunctionWrapHandler) -> T:
            if isinstance(value, self.base):
                return value
            if not isinstance(value, dict):
                raise PydanticCustomError("spec_type", "expected a mapping with a '{key}' field", {"key": self.key})
            name = value.get(self.key)
            if name is None:
                raise PydanticCustomError(
                    "spec_type",
                    "missing '{key}'; expected one of: {names}",
                    {"key": self.key, "names": ", ".join(self.names())},
                )
            if name not in self._types:
                raise PydanticCustomError(
                    "spec_type",
                    "unknown {kind}{what} '{name}'; {hint}",
                    {
                        "kind": self.kind,
                        "what": " type" if self.key == "type" else "",
                        "name": str(name),
                        "hint": suggest(str(name), self._types.names()),
                    },
                )
            return self._types.get(name).model_validate(value)

        return dispatch

    def field_type(self) -> Any:
        """The annotation for a field holding one spec of this registry."""
        return Annotated[SerializeAsAny[self.base], WrapValidator(self.validator())]  # type: ignore[name-defined,misc]
