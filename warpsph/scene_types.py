"""A scene's values as a scene file writes them, checked and converted to the dataclasses' field types;
key paths and values rendered for messages, and the checks of one value (a range, a choice, a name)
(docs/scenes.md). Shared by the TOML reader, the checks and the phases' changes."""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import re
import types
import typing
from collections.abc import Iterable, Sequence

import numpy as np

from warpsph.errors import SceneError
from warpsph.scene_sections import Material, Region, Simulation

UNBOUNDED_FIELDS = {
    (Simulation, "velocity_limit"),
    (Region, "min"),
    (Region, "max"),
    (Material, "grain_bulk_modulus"),
    (Material, "water_bulk_modulus"),
}
"""Number fields that may be ±infinity (all others must be finite)."""
NAME = re.compile(r"[A-Za-z0-9_-]+")
"""A usable name of a scene item."""


# --------------------------------------------------------------------------- rendering


def show(value) -> str:
    """A value as it would be written in a scene file (strings quoted, booleans lower case)."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return number_text(float(value))
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(show(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {show(v)}" for k, v in value.items()) + "}"
    if value is None:
        return "nothing"
    return type(value).__name__


def number_text(x: float) -> str:
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)


def join_key(key: str, name: str) -> str:
    """``key.name``, or ``name`` at the top level."""
    return f"{key}.{name}" if key else name


def item_key(section: str, name, index: int) -> str:
    """Key path of a named list item: ``section.name``, or ``section[index]`` if the name is unusable."""
    if isinstance(name, str) and NAME.fullmatch(name):
        return f"{section}.{name}"
    return f"{section}[{index}]"


# --------------------------------------------------------------------------- types and conversion


def as_number(key: str, value, finite: bool = True) -> float:
    """``value`` as a float; booleans are not numbers; NaN never, infinities only if not ``finite``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise SceneError(key, f"expected a number, got {show(value)}")
    x = float(value)
    if math.isnan(x) or (finite and math.isinf(x)):
        raise SceneError(key, f"expected a finite number, got {show(value)}")
    return x


def as_integer(key: str, value) -> int:
    """``value`` as an int (booleans and floats are refused)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise SceneError(key, f"expected an integer, got {show(value)}")
    return int(value)


def as_bool(key: str, value) -> bool:
    """``value`` as a bool (true or false, not numbers)."""
    if not isinstance(value, (bool, np.bool_)):
        raise SceneError(key, f"expected true or false, got {show(value)}")
    return bool(value)


def as_string(key: str, value) -> str:
    """``value`` as a str."""
    if not isinstance(value, str):
        raise SceneError(key, f"expected a string, got {show(value)}")
    return value


def as_numbers(key: str, value, size: int, pad: bool, finite: bool = True) -> tuple[float, ...]:
    """A list of ``size`` numbers as a tuple; with ``pad`` 1..``size`` numbers, zero-padded."""
    fewest = 1 if pad else size
    wanted = f"{fewest} to {size} numbers" if fewest < size else f"{size} numbers"
    if not is_list(value) or not fewest <= len(value) <= size:
        raise SceneError(key, f"expected a list of {wanted}, got {show(value)}")
    xs = tuple(as_number(f"{key}[{i}]", v, finite) for i, v in enumerate(value))
    return xs + (0.0,) * (size - len(xs))


def convert(key: str, value, hint, pad: bool = False, finite: bool = True):
    """Check ``value`` against a dataclass field's leaf type ``hint`` and convert it to that type.

    Leaf types are float, int, bool, str, fixed-size tuples of floats and lists of those. With
    ``pad`` (scene files), 3-component vectors may be written with 1 to 3 numbers.
    """
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if hint is float:
        return as_number(key, value, finite)
    if hint is int:
        return as_integer(key, value)
    if hint is bool:
        return as_bool(key, value)
    if hint is str:
        return as_string(key, value)
    if origin is tuple:
        return as_numbers(key, value, len(args), pad and len(args) == 3, finite)
    if origin is list:
        if not is_list(value):
            raise SceneError(key, f"expected a list, got {show(value)}")
        return [convert(f"{key}[{i}]", v, args[0], pad, finite) for i, v in enumerate(value)]
    if origin is dict and args[1] is object:  # key paths to values, checked where they are applied
        if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
            raise SceneError(key, f"expected a table of key paths and values, got {show(value)}")
        return dict(value)
    raise TypeError(f"{key}: unsupported field type {hint!r}")


@functools.cache
def field_hints(cls) -> dict[str, object]:
    """Resolved type hints of the dataclass ``cls``'s fields, in declaration order."""
    hints = typing.get_type_hints(cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls)}


def optional_inner(hint):
    """``X`` for a hint ``X | None``, else None."""
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        if len(args) == 1:
            return args[0]
    return None


def is_finite_field(cls, name: str) -> bool:
    """Whether the number field ``cls.name`` must be finite."""
    return (cls, name) not in UNBOUNDED_FIELDS


def check_types(obj, key: str) -> None:
    """Check every field of the dataclass instance ``obj`` (recursively) against its declared type."""
    for name, hint in field_hints(type(obj)).items():
        value, field_key = getattr(obj, name), join_key(key, name)
        inner = optional_inner(hint)
        if inner is not None:
            if value is None:
                continue
            hint = inner
        if dataclasses.is_dataclass(hint):
            check_instance(field_key, value, hint)
            check_types(value, field_key)
        else:
            convert(field_key, value, hint, finite=is_finite_field(type(obj), name))


def check_instance(key: str, value, cls) -> None:
    """Raise unless ``value`` is a ``cls`` instance (for Python-built scenes)."""
    if not isinstance(value, cls):
        raise SceneError(key, f"expected a {cls.__name__}, got {type(value).__name__}")


def is_list(value) -> bool:
    """Whether ``value`` is a list as a scene file or the Python API writes one."""
    return isinstance(value, (list, tuple, np.ndarray))


# --------------------------------------------------------------------------- TOML values


def from_table(cls, key: str, table, exclude: tuple[str, ...] = (), **given):
    """Build the dataclass ``cls`` from the TOML table at ``key``; ``given`` fills excluded fields."""
    if not isinstance(table, dict):
        raise SceneError(key, f"expected a table, got {show(table)}")
    hints = {n: h for n, h in field_hints(cls).items() if n not in exclude}
    for k in table:
        if k not in hints:
            what = "key" if key else "section"
            raise SceneError(join_key(key, k), f"unknown {what}; accepted: {', '.join(sorted(hints))}")
    values = {n: _from_value(cls, n, join_key(key, n), table[n], hints[n]) for n in hints if n in table}
    return cls(**values, **given)


def convert_field(owner, name: str, key: str, value):
    """The TOML ``value`` of field ``owner.name`` converted as a scene file's, errors naming ``key``."""
    return _from_value(owner, name, key, value, field_hints(owner)[name])


def _from_value(owner, name: str, key: str, value, hint):
    """Convert the TOML value of field ``owner.name`` (type ``hint``) found at ``key``."""
    hint = optional_inner(hint) or hint
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if dataclasses.is_dataclass(hint) and isinstance(value, hint):  # already typed (the Python API, a change)
        check_types(value, key)
        return value
    if dataclasses.is_dataclass(hint):
        return from_table(hint, key, value)
    if origin is dict and args[1] is not object:
        return _named_tables(key, value, args[1])
    if origin is list and dataclasses.is_dataclass(args[0]):
        return _array_of_tables(key, value, args[0])
    return convert(key, value, hint, pad=True, finite=is_finite_field(owner, name))


def _named_tables(key: str, value, cls) -> dict:
    """``[key.<name>]`` tables as {name: cls(name=name, ...)}."""
    if not isinstance(value, dict):
        raise SceneError(key, f"expected tables [{key}.<name>], got {show(value)}")
    return {k: from_table(cls, f"{key}.{k}", v, exclude=("name",), name=k) for k, v in value.items()}


def _array_of_tables(key: str, value, cls) -> list:
    """``[[key]]`` tables as a list of cls; a missing name defaults to e.g. "body0", "body1", ..."""
    if not isinstance(value, list):
        raise SceneError(key, f"expected an array of tables [[{key}]], got {show(value)}")
    items = []
    for i, table in enumerate(value):
        if not isinstance(table, dict):
            raise SceneError(f"{key}[{i}]", f"expected a table, got {show(table)}")
        name = table.get("name", f"{cls.__name__.lower()}{i}")
        given = {} if "name" in table else {"name": name}
        items.append(from_table(cls, item_key(key, name, i), table, **given))
    return items


# --------------------------------------------------------------------------- value checks


@dataclasses.dataclass(frozen=True)
class Interval:
    """A range of real numbers; each end open or closed, possibly infinite."""

    lo: float = -math.inf
    hi: float = math.inf
    lo_closed: bool = False
    hi_closed: bool = False

    def __contains__(self, x: float) -> bool:
        above = x >= self.lo if self.lo_closed else x > self.lo
        below = x <= self.hi if self.hi_closed else x < self.hi
        return above and below

    def __str__(self) -> str:
        lo, hi = number_text(self.lo).removesuffix(".0"), number_text(self.hi).removesuffix(".0")
        if math.isinf(self.hi):
            return f"{'>=' if self.lo_closed else '>'} {lo}"
        if math.isinf(self.lo):
            return f"{'<=' if self.hi_closed else '<'} {hi}"
        return f"in {'[' if self.lo_closed else '('}{lo}, {hi}{']' if self.hi_closed else ')'}"


POSITIVE = Interval(0.0, hi_closed=True)
NON_NEGATIVE = Interval(0.0, lo_closed=True, hi_closed=True)
UNIT_INTERVAL = Interval(0.0, 1.0)
WATER_DENSITIES = Interval(500.0, 2000.0, True, True)
"""Water densities [kg/m³] that are plausible; others are taken for a unit mistake."""
FRICTION_ANGLES = Interval(0.0, 90.0, lo_closed=True)
"""Friction angles φ [degrees] accepted: [0°, 90°)."""


def check_range(key: str, value: float, interval: Interval, note: str = "") -> None:
    """Raise unless ``value`` lies in ``interval``; ``note`` says why the bound is there."""
    if value not in interval:
        raise SceneError(key, f"must be {interval}{note}, got {show(value)}")


def check_choice(key: str, value, choices: Iterable, note: str = "") -> None:
    """Raise unless ``value`` is one of ``choices``; ``note`` explains a restriction (e.g. the dim)."""
    choices = tuple(choices)
    if value not in choices:
        accepted = ", ".join(show(c) for c in choices)
        raise SceneError(key, f"must be one of {accepted}{note}, got {show(value)}")


def check_unique(what: str, *sections: tuple[str, Sequence]) -> None:
    """Raise on the first name repeated among the items of the (section, items) pairs."""
    seen: dict[str, str] = {}
    for section, items in sections:
        for i, item in enumerate(items):
            if item.name in seen:
                raise SceneError(
                    f"{item_key(section, item.name, i)}.name",
                    f"duplicate {what} name {show(item.name)} ({seen[item.name]} and {section}[{i}])",
                )
            seen[item.name] = f"{section}[{i}]"


def check_name(key: str, name) -> None:
    """Raise unless ``name`` is a non-empty string of letters, digits, '_' and '-'."""
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise SceneError(key, f"must be a non-empty string of letters, digits, '_' or '-', got {show(name)}")
