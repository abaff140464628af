"""The pydantic types of the scenario models, and how a scenario holds a msgspec Struct (its ``rover_params``).

The wire models and the rover parameters are msgspec Structs (a rover agent imports no pydantic); scenarios stay
pydantic models for their error reports: every problem of a file listed with its path, a misspelt field matched to
the one it probably meant (``schemas.scenario_errors``). A Struct a scenario holds is validated there by its
*mirror*, a pydantic model built from the Struct's own fields (bounds and descriptions from the same msgspec
``Meta``, cross-field rules from the same ``__post_init__``), then converted to the Struct: one definition of each
field, the scenario loader's messages for every problem in it.
"""

from __future__ import annotations

import functools
import types
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import msgspec
from msgspec import Meta
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, create_model, model_validator
from pydantic.json_schema import GenerateJsonSchema
from pydantic_core import core_schema

from schemas import scenario_limits as limits
from schemas import wire_limits

_META_FIELDS = ("ge", "gt", "le", "lt", "min_length", "max_length", "pattern", "description")
_BOUNDS = ("ge", "gt", "le", "lt")


def field_type(annotation: Any) -> Any:
    """A msgspec annotation as pydantic reads it: each ``Meta`` as a ``Field`` of the same bounds and description
    (the ``FLOAT_MAX`` bounds that only keep a float finite are ``allow_inf_nan=False`` on the mirror instead), a
    Struct as its mirror, through unions and containers."""
    origin = get_origin(annotation)
    if origin is Annotated:
        base, *extras = get_args(annotation)
        kwargs = {name: value for meta in extras if isinstance(meta, Meta) for name in _META_FIELDS
                  if (value := getattr(meta, name)) is not None
                  and not (name in _BOUNDS and abs(value) == wire_limits.FLOAT_MAX)}
        return Annotated[field_type(base), Field(**kwargs)] if kwargs else field_type(base)
    if isinstance(annotation, type) and issubclass(annotation, msgspec.Struct):
        return mirror(annotation)
    if origin is None or origin is Literal:
        return annotation
    args = tuple(field_type(a) for a in get_args(annotation))
    if origin in (Union, types.UnionType):
        return Union[args]  # noqa: UP007 (built from a tuple)
    return origin[args]


class Mirror(BaseModel):
    """Base of every mirror: as strict as the Struct (unknown fields refused, floats finite)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


@functools.cache
def mirror(struct: type[msgspec.Struct]) -> type[Mirror]:
    """The pydantic model that validates what ``struct`` holds, field for field, under the Struct's name (so JSON
    Schemas and the reference pages name it as users know it)."""
    fields: dict[str, Any] = {}
    for info in msgspec.structs.fields(struct):
        kind = field_type(info.type)
        if info.default is not msgspec.NODEFAULT:
            fields[info.name] = (kind, _mirrored(info.default))
        elif info.default_factory is not msgspec.NODEFAULT:
            fields[info.name] = (kind, Field(default_factory=info.default_factory))
        else:
            fields[info.name] = (kind, ...)
    checks = {}
    if (post_init := getattr(struct, "__post_init__", None)) is not None:
        checks["_struct_checks"] = model_validator(mode="after")(_run(post_init))
    return create_model(struct.__name__, __base__=Mirror, __doc__=struct.__doc__, __validators__=checks, **fields)


def _run(post_init: Any) -> Any:
    def check(self: Mirror) -> Mirror:
        post_init(self)  # the Struct's own rule, on the mirror's fields of the same names
        return self
    return check


def _mirrored(default: object) -> object:
    if isinstance(default, msgspec.Struct):
        return mirror(type(default)).model_validate(msgspec.to_builtins(default))
    return default


def to_struct(struct: type[msgspec.Struct], model: BaseModel) -> Any:
    """The Struct a validated mirror stands for."""
    return msgspec.convert(model.model_dump(), struct)


def non_default(value: msgspec.Struct) -> dict[str, Any]:
    """The fields of ``value`` that differ from their defaults, nested Structs the same way: what a scenario file
    written back (``dump_scenario``) says of it."""
    out: dict[str, Any] = {}
    for info in msgspec.structs.fields(value):
        field = getattr(value, info.name)
        default = info.default if info.default_factory is msgspec.NODEFAULT else info.default_factory()
        if field != default:
            out[info.name] = non_default(field) if isinstance(field, msgspec.Struct) else msgspec.to_builtins(field)
    return out


class _StructAdapter:
    """Validates a Struct field of a pydantic model by the Struct's mirror; holds and dumps the Struct itself."""

    def __init__(self, struct: type[msgspec.Struct]) -> None:
        self.struct = struct

    def __get_pydantic_core_schema__(self, source: Any, handler: Any) -> core_schema.CoreSchema:
        checked = core_schema.no_info_after_validator_function(
            functools.partial(to_struct, self.struct), handler.generate_schema(mirror(self.struct)))
        return core_schema.no_info_before_validator_function(
            self._as_data, checked,
            serialization=core_schema.plain_serializer_function_ser_schema(self._dump, info_arg=True))

    def _as_data(self, value: object) -> object:
        return msgspec.to_builtins(value) if isinstance(value, self.struct) else value

    @staticmethod
    def _dump(value: msgspec.Struct, info: core_schema.SerializationInfo) -> dict[str, Any]:
        return non_default(value) if info.exclude_defaults else msgspec.to_builtins(value)


def struct_field(struct: type[msgspec.Struct]) -> Any:
    """The annotation of a pydantic field holding ``struct``: ``rover_params: struct_field(RoverParams)``."""
    return Annotated[struct, _StructAdapter(struct)]


class StructDefaults(GenerateJsonSchema):
    """JSON Schema generation that shows a Struct default (a scenario's ``rover_params``) as its fields, as it
    shows a pydantic model's: ``Scenario.model_json_schema(schema_generator=StructDefaults)``."""

    def encode_default(self, dft: Any) -> Any:
        return msgspec.to_builtins(dft) if isinstance(dft, msgspec.Struct) else super().encode_default(dft)


Coordinate = field_type(wire_limits.Coordinate)
SafeName = Annotated[str, AfterValidator(limits.safe_name)]
BehaviourSpec = Annotated[str, AfterValidator(limits.behaviour_spec)]
