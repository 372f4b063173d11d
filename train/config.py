"""An algorithm's config: a dataclass of fields, JSON overrides from `--config FILE`, and every field checked (name,
type, range) before any work starts, with messages that name the field and what is valid.

Each algorithm module declares `LIMITS = {field: rule}` next to its config class; a rule is one of the helpers below.
"""
from __future__ import annotations

import dataclasses
import json
import math
import typing
from pathlib import Path


class Rule(typing.NamedTuple):
    text: str  # what is valid, for the message
    ok: typing.Callable[[object], bool]


def at_least(low) -> Rule:
    return Rule(f">= {low}", lambda x: x >= low)


def positive() -> Rule:
    return Rule("> 0", lambda x: x > 0)


def unit_interval(open_low: bool = False) -> Rule:
    return Rule("in (0, 1]" if open_low else "in [0, 1]", lambda x: (x > 0 if open_low else x >= 0) and x <= 1)


def one_of(*choices) -> Rule:
    return Rule(f"one of {', '.join(map(str, choices))}", lambda x: x in choices)


def sizes() -> Rule:
    return Rule("a list of positive integers", lambda xs: all(x >= 1 for x in xs))


def _typed(name: str, value, hint):
    """`value` as the field's declared type (int, float, bool, str, list[int], tuple[int, ...]) or ValueError."""
    origin = typing.get_origin(hint)
    if origin in (list, tuple):
        if not isinstance(value, (list, tuple)) or any(isinstance(x, bool) or not isinstance(x, int) for x in value):
            raise ValueError(f"{name} must be a list of integers, got {value!r}")
        return origin(value)
    if hint is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{name} must be true or false, got {value!r}")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{name} must be an integer, got {value!r}")
        return value
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"{name} must be a finite number, got {value!r}")
        return float(value)
    if hint is str and not isinstance(value, str):
        raise ValueError(f"{name} must be a string, got {value!r}")
    return value


def check(cfg, limits: dict[str, Rule]):
    """`cfg` with every field of its declared type and within its rule; ValueError naming the first bad field."""
    hints = typing.get_type_hints(type(cfg))
    values = {}
    for f in dataclasses.fields(cfg):
        value = _typed(f.name, getattr(cfg, f.name), hints[f.name])
        rule = limits.get(f.name)
        if rule is not None and not rule.ok(value):
            raise ValueError(f"{f.name} = {value!r} is out of range: it must be {rule.text}")
        values[f.name] = value
    return dataclasses.replace(cfg, **values)


def read_overrides(path: Path | None, cls) -> dict:
    """The JSON object in `path` ({} for None), its field names checked against `cls`."""
    if path is None:
        return {}
    try:
        overrides = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"config file {path}: {exc}") from exc
    if not isinstance(overrides, dict):
        raise ValueError(f"config file {path}: expected a JSON object of field: value, got {type(overrides).__name__}")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(overrides) - names)
    if unknown:
        raise ValueError(f"config file {path}: unknown field(s) {unknown}; valid: {sorted(names)}")
    return overrides


def build(cls, limits: dict[str, Rule], base=None, overrides: dict | None = None, source: str = "config"):
    """`base` (default: `cls()`) with `overrides` applied, checked; errors name `source`."""
    try:
        return check(dataclasses.replace(base if base is not None else cls(), **(overrides or {})), limits)
    except ValueError as exc:
        raise ValueError(f"{source}: {exc}") from None
