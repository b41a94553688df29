"""Strict configuration: TOML files and ``--set key=value`` into frozen dataclasses.

A config class is a frozen :func:`dataclasses.dataclass` whose fields carry type hints
(``int``, ``float``, ``bool``, ``str``, ``Literal[...]``, ``X | None``, ``tuple[...]``
and nested config dataclasses).  :func:`from_mapping` converts a plain mapping (a parsed
TOML document) into an instance and rejects, with a one-line :class:`ConfigError` that
names the key and the source:

- a key the class does not have (with the list of keys it does have),
- a value of the wrong type (``n = "ten"``, ``n = 2.5`` for an integer),
- a value outside ``Literal`` choices.

Range checks live in each class's ``__post_init__``, written with :func:`check`, whose
messages name the field; :func:`from_mapping` adds the source to them.

Example
-------
>>> @dataclasses.dataclass(frozen=True)
... class Box:
...     n: int = 100
...     kT: float = 50.0
>>> from_mapping(Box, {"n": 10}, source="box.toml")
Box(n=10, kT=50.0)
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Literal, TypeVar, get_args, get_origin

import tomli_w

from thermoswarm.errors import ConfigError

T = TypeVar("T")

__all__ = [
    "check",
    "from_mapping",
    "load_toml",
    "apply_overrides",
    "parse_overrides",
    "to_dict",
    "dumps_toml",
    "replace",
]


def check(condition: bool, field: str, expectation: str, value: Any = None) -> None:
    """Raise :class:`ConfigError` ``"<field> must be <expectation>, got <value>"`` if false."""
    if not condition:
        raise ConfigError(f"{field} must be {expectation}, got {value!r}")


def check_positive(field: str, value: float, expectation: str = "a positive number") -> None:
    """:func:`check` that ``value`` is finite and above zero."""
    check(math.isfinite(value) and value > 0, field, expectation, value)


def _type_name(tp: Any) -> str:
    origin = get_origin(tp)
    if tp is int:
        return "an integer"
    if tp is float:
        return "a number"
    if tp is bool:
        return "true or false"
    if tp is str:
        return "a string"
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(tp))
    if origin in (types.UnionType, typing.Union):
        names = [_type_name(a) for a in get_args(tp) if a is not type(None)]
        return " or ".join(names)
    if origin in (tuple, list):
        return "a list"
    if dataclasses.is_dataclass(tp):
        return "a table"
    return getattr(tp, "__name__", str(tp))


def _convert(value: Any, tp: Any, key: str) -> Any:
    """Convert ``value`` to type ``tp`` or raise a ConfigError naming ``key``."""
    origin = get_origin(tp)
    bad = ConfigError(f"{key} must be {_type_name(tp)}, got {value!r}")
    if tp is Any:
        return value
    if origin in (types.UnionType, typing.Union):
        args = get_args(tp)
        if value is None and type(None) in args:
            return None
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(value, arg, key)
            except ConfigError:
                continue
        raise bad
    if origin is Literal:
        if value in get_args(tp) and type(value) in {type(a) for a in get_args(tp)}:
            return value
        raise bad
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise bad
    if tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
            return int(value)
        raise bad
    if tp is float:
        if isinstance(value, int | float) and not isinstance(value, bool):
            v = float(value)
            if math.isnan(v):
                raise ConfigError(f"{key} must be a number, got nan")
            return v
        raise bad
    if tp is str:
        if isinstance(value, str):
            return value
        raise bad
    if origin is tuple or origin is list:
        if isinstance(value, str) or not isinstance(value, Iterable):
            raise bad
        items = list(value)
        args = get_args(tp)
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(items) != len(args):
                raise ConfigError(f"{key} must be a list of {len(args)} items, got {value!r}")
            pairs = enumerate(zip(items, args, strict=True))
            return tuple(_convert(v, a, f"{key}[{i}]") for i, (v, a) in pairs)
        inner = args[0] if args else Any
        return tuple(_convert(v, inner, f"{key}[{i}]") for i, v in enumerate(items))
    if dataclasses.is_dataclass(tp):
        if isinstance(value, tp):
            return value
        if not isinstance(value, Mapping):
            raise bad
        return _from_mapping(tp, value, prefix=key + ".")
    raise TypeError(f"unsupported config field type {tp!r} for {key}")


def _from_mapping(cls: type[T], data: Mapping[str, Any], prefix: str = "") -> T:
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = [k for k in data if k not in fields]
    if unknown:
        expected = ", ".join(sorted(fields))
        raise ConfigError(f"unknown key {prefix + unknown[0]!r}; expected one of: {expected}")
    kwargs = {k: _convert(v, hints[k], prefix + k) for k, v in data.items()}
    try:
        return cls(**kwargs)
    except ConfigError as exc:
        msg = str(exc)
        if prefix and not msg.startswith(prefix):
            msg = prefix + msg
        raise ConfigError(msg) from None


def from_mapping(cls: type[T], data: Mapping[str, Any], *, source: str | None = None) -> T:
    """Build config class ``cls`` from ``data``; errors name ``source`` and the key."""
    try:
        return _from_mapping(cls, data)
    except ConfigError as exc:
        if source:
            raise ConfigError(f"{source}: {exc}") from None
        raise


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file; a missing file or a syntax error is a one-line ConfigError."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"config file {str(path)!r} does not exist") from None
    except IsADirectoryError:
        raise ConfigError(f"config file {str(path)!r} is a directory") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a UTF-8 text file") from None


def parse_value(text: str) -> Any:
    """Parse the right-hand side of ``--set key=value`` as a TOML value.

    Bare words that are not TOML (``--set variant=obstacle``) are taken as strings.
    """
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_overrides(items: Iterable[str]) -> dict[str, Any]:
    """Turn ``["a=1", "b.c=x"]`` into the nested mapping ``{"a": 1, "b": {"c": "x"}}``."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ConfigError(f"--set {item!r}: expected key=value")
        node = out
        parts = key.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ConfigError(f"--set {item!r}: {part!r} is set twice")
        node[parts[-1]] = parse_value(text.strip())
    return out


def apply_overrides(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """Deep-merge ``overrides`` into a copy of ``base``."""
    out = dict(base)
    for k, v in overrides.items():
        if isinstance(v, Mapping) and isinstance(out.get(k), Mapping):
            out[k] = apply_overrides(out[k], v)
        else:
            out[k] = v
    return out


def to_dict(obj: Any) -> Any:
    """Config instance -> plain dict (tuples as lists, ``None`` fields left out)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out = {}
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if v is None:
                continue
            out[f.name] = to_dict(v)
        return out
    if isinstance(obj, tuple | list):
        return [to_dict(v) for v in obj]
    return obj


def dumps_toml(obj: Any) -> str:
    """The fully resolved config as TOML text (loadable by :func:`from_mapping`)."""
    data = to_dict(obj) if dataclasses.is_dataclass(obj) else obj
    return tomli_w.dumps(data)


def replace(obj: T, **changes: Any) -> T:
    """:func:`dataclasses.replace` with the same checks as :func:`from_mapping`."""
    data = to_dict(obj)
    data.update(changes)
    return from_mapping(type(obj), data)
