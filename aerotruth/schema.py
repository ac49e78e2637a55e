"""The base of every configuration schema (pydantic): a campaign file's sections, each
sensor's and each method's spec. A leaf module, so that truth, sensors and analysis can
declare their specs without importing the campaign loader.

A number field takes numbers only: pydantic would take YAML's `true` for 1 (and `no` for 0),
so `hours_utc: [true]` would be an hour after midnight. A field whose type holds `int` or
`float` and not `bool` refuses true/false, in a list or a mapping too."""

from __future__ import annotations

import functools
import typing
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationInfo, field_validator


def _takes_numbers_not_booleans(annotation: Any) -> str:
    """_number_field's answer, cached where the type can be (an unhashable metadata object in
    an Annotated type cannot)."""
    try:
        return _number_field(annotation)
    except TypeError:
        return _number_field.__wrapped__(annotation)


@functools.lru_cache(maxsize=4096)
def _number_field(annotation: Any) -> str:
    """What a field type takes when it holds int or float and nowhere bool: "an integer"
    (int only) or "a number"; "" for any other type (Annotated, unions, lists, tuples and
    mappings unwrapped; a nested model validates its own fields)."""
    found: set[type] = set()

    def walk(tp: Any) -> None:
        if tp in (bool, int, float):
            found.add(tp)
        elif typing.get_origin(tp) is not typing.Literal:
            for arg in typing.get_args(tp):
                walk(arg)

    walk(annotation)
    if not found or bool in found:
        return ""
    return "an integer" if found == {int} else "a number"


def _holds_boolean(value: Any, depth: int = 0) -> bool:
    if isinstance(value, bool):
        return True
    if depth < 4 and isinstance(value, (list, tuple)):
        return any(_holds_boolean(v, depth + 1) for v in value)
    if depth < 4 and isinstance(value, dict):
        return any(_holds_boolean(v, depth + 1) for v in value.values())
    return False


class Section(BaseModel):
    """Base of every schema block: unknown keys are errors, values are immutable, a number
    field takes no true/false (module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    @field_validator("*", mode="before")
    @classmethod
    def _no_booleans_for_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        if info.field_name is None or not _holds_boolean(value):
            return value
        field = cls.model_fields.get(info.field_name)
        expected = _takes_numbers_not_booleans(field.annotation) if field is not None else ""
        if expected:
            shown = str(value).lower() if isinstance(value, bool) else "true/false among the values"
            raise ValueError(f"expected {expected}, got {shown}")
        return value
