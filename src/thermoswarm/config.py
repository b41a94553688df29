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
import difflib
import inspect
import math
import re
import tomllib
import types
import typing
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, TypeVar, get_args, get_origin

import tomli_w

from thermoswarm.errors import ConfigError

T = TypeVar("T")

__all__ = [
    "check",
    "check_magnitudes",
    "loads_value",
    "shown",
    "from_mapping",
    "load_toml",
    "apply_overrides",
    "parse_overrides",
    "to_dict",
    "dumps_toml",
    "replace",
    "describe",
    "standin",
    "type_spec",
    "type_from_spec",
]


def shown(value: Any, limit: int = 60) -> str:
    """``repr(value)`` for a message: NumPy scalars as plain numbers, at most ``limit``
    characters (an integer of thousands of digits is cut, not printed)."""
    if hasattr(value, "item") and getattr(value, "ndim", None) == 0:
        value = value.item()
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**limit:
        return f"an integer of about {int(value.bit_length() * 0.30103)} digits"
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def check(condition: bool, field: str, expectation: str, value: Any = None) -> None:
    """Raise :class:`ConfigError` ``"<field> must be <expectation>, got <value>"`` if false."""
    if not condition:
        raise ConfigError(f"{field} must be {expectation}, got {shown(value)}")


def check_magnitudes(
    obj: Any,
    source: str,
    *,
    smallest: float,
    largest: float,
    what: str,
    prefix: str = "",
    unbounded: tuple[str, ...] = (),
) -> None:
    """Refuse a finite, non-zero float field of config ``obj`` (nested sections and
    tuples included) whose magnitude is outside ``[smallest, largest]``, naming its key;
    the keys in ``unbounded`` (dotted) are checked against ``smallest`` only.

    Raises
    ------
    ConfigError
        ``"<source>: <key> = <value> is outside <what> (magnitude A to B, or 0)"``.
    """
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        key = prefix + f.name
        if dataclasses.is_dataclass(v):
            check_magnitudes(v, source, smallest=smallest, largest=largest, what=what,
                             prefix=key + ".", unbounded=unbounded)  # fmt: skip
            continue
        top = math.inf if key in unbounded else largest
        for x in v if isinstance(v, tuple) else (v,):
            if isinstance(x, float) and math.isfinite(x) and x != 0.0:
                if not smallest <= abs(x) <= top:
                    raise ConfigError(
                        f"{source}: {key} = {x!r} is outside {what} "
                        f"(magnitude {smallest:g} to {largest:g}, or 0)"
                    )


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
    bad = ConfigError(f"{key} must be {_type_name(tp)}, got {shown(value)}")
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
            if not -(2**63) <= value < 2**63:
                raise ConfigError(f"{key} must be a 64-bit integer, got {shown(value)}")
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
        hint = _did_you_mean(cls, unknown[0], prefix)
        raise ConfigError(
            f"unknown key {prefix + unknown[0]!r}{hint}; expected one of: {expected}"
        )
    kwargs = {k: _convert(v, hints[k], prefix + k) for k, v in data.items()}
    try:
        return cls(**kwargs)
    except ConfigError as exc:
        msg = str(exc)
        if prefix and not msg.startswith(prefix):
            msg = prefix + msg
        raise ConfigError(msg) from None


def _did_you_mean(cls: type, key: str, prefix: str) -> str:
    """`` (did you mean 'engine.dt'?)`` for a typo or a key of a nested section."""
    if not isinstance(key, str):
        return ""
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls) if f.init]
    close = difflib.get_close_matches(key, names, n=1, cutoff=0.75)
    if close:
        return f" (did you mean {prefix + close[0]!r}?)"
    for name in names:  # `dt` written for `engine.dt`
        tp = hints[name]
        if dataclasses.is_dataclass(tp) and key in {f.name for f in dataclasses.fields(tp)}:
            return f" (did you mean {prefix + name + '.' + key!r}?)"
    close = difflib.get_close_matches(key.lower(), [n.lower() for n in names], n=1, cutoff=0.6)
    if close:
        real = next(n for n in names if n.lower() == close[0])
        return f" (did you mean {prefix + real!r}?)"
    return ""


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
    except RecursionError:
        raise ConfigError(f"{path}: arrays or tables nested too deeply") from None
    except ValueError as exc:  # an integer of more than 4,300 digits
        raise ConfigError(f"{path}: a number too long to read ({_first(exc)})") from None
    except OSError as exc:
        raise ConfigError(f"config file {str(path)!r} cannot be read ({exc.strerror})") from None


def _first(exc: BaseException) -> str:
    return (str(exc).splitlines() or [type(exc).__name__])[0][:120]


def loads_value(text: str, what: str) -> Any:
    """Parse ``text`` as one TOML value (``what`` names it in errors).

    Bare words that are not TOML (``obstacle``, ``mm``) are taken as strings; values
    nested too deeply or integers too long to read are a one-line :class:`ConfigError`.
    """
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:
        raise ConfigError(f"{what}: the value is nested too deeply") from None
    except ValueError as exc:
        raise ConfigError(f"{what}: a number too long to read ({_first(exc)})") from None


def parse_value(text: str) -> Any:
    """Parse the right-hand side of ``--set key=value`` as a TOML value.

    Bare words that are not TOML (``--set variant=obstacle``) are taken as strings.
    """
    return loads_value(text, f"value {text[:40]!r}")


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
        if parts[-1] in node:
            raise ConfigError(f"--set {key!r} is given twice (give each key once)")
        node[parts[-1]] = loads_value(text.strip(), f"--set {key}")
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


# ----------------------------------------------------------------------------- listing
# What `thermoswarm scenarios NAME` prints and what `--set` is checked against before
# the heavy modules are imported: every field of a config class (nested sections as
# dotted keys) with its type, default, unit and one-line meaning, as plain data.  The
# unit and meaning come from the class's numpydoc "Attributes"/"Parameters" section.

_UNIT = re.compile(
    r"^(mm\^2/s\^2|mm/s|mm|s|deg/s|deg|rad/s|rad|J|px|fps|robot drags|drag units)"
    r"(?: per unit mass)?$"
)


def _field_docs(cls: type) -> dict[str, str]:
    """``{field: description}`` from the class docstring's Attributes/Parameters."""
    doc = inspect.getdoc(cls) or ""
    out: dict[str, str] = {}
    lines = doc.splitlines()
    in_section = False
    names: list[str] = []
    for i, line in enumerate(lines):
        if line.strip() in ("Attributes", "Parameters") and i + 1 < len(lines):
            in_section = set(lines[i + 1].strip()) == {"-"}
            names = []
            continue
        if not in_section or set(line.strip()) == {"-"}:
            continue
        if line and not line.startswith(" "):
            head = line.split(" : ")[0] if " : " in line else line.split(":")[0]
            if not re.fullmatch(r"[A-Za-z_][\w]*(, *[A-Za-z_][\w]*)*", head.strip()):
                in_section = False
                continue
            names = [n.strip() for n in head.split(",")]
            for n in names:
                out.setdefault(n, "")
        elif names:
            for n in names:
                out[n] = (out[n] + " " + line.strip()).strip()
    return out


def _unit_of(name: str, kind: str, text: str) -> str:
    if kind not in ("int", "float", "tuple", "optional"):
        return ""
    for group in re.findall(r"\(([^()]*)\)", text):
        first = re.split(r"[,;]", group)[0].strip()
        if _UNIT.match(first):
            return first.replace(" per unit mass", "")
        for piece in re.split(r"[,;]", group):
            m = re.match(r"^\s*(?:in\s+)?(robot drags|drag units)\b", piece)
            if m:
                return m.group(1)
    low = text.lower()
    if low.startswith(("simulated seconds", "seconds")):
        return "s"
    m = re.search(r"\bin (robot drags|drag units)\b", low)
    if m:
        return m.group(1)
    # the house's conventions (mm, s, mm^2/s^2) where the text states no unit
    if name.endswith("_deg"):
        return "deg"
    if re.fullmatch(r"kT(_[a-z]+)?", name) and name != "kT_theta":
        return "mm^2/s^2"
    if re.search(r"(^|_)(x|y|dx|dy|radius|diameter|width|height|length|distance|amplitude|"
                 r"leg|depth|clearance|taper)$", name):  # fmt: skip
        return "mm"
    if re.search(r"\bfraction\b|\bratio\b|\bprobability\b|robot area /", low):
        return "1"
    if re.search(r"\blight level\b|\breading\b|light-level units|standard deviation", low):
        return "light level"
    if "relaxation times" in low:
        return "t_relax"
    if name.endswith("threshold"):
        return "light level"
    if name.endswith("tolerance"):
        return "1"
    return ""


def _meaning(text: str) -> str:
    """The first sentence of a description (outside parentheses), at most 90 characters."""
    text = re.sub(r":(class|meth|func|attr|mod):`~?([^`]*)`", r"\2", text)
    text = re.sub(r"``([^`]*)``", r"\1", text).strip()
    depth, end = 0, len(text)
    for i, ch in enumerate(text):
        depth += {"(": 1, "[": 1, ")": -1, "]": -1}.get(ch, 0)
        if depth == 0 and ch in ".;" and (i + 1 == len(text) or text[i + 1] == " "):
            end = i
            break
    first = text[:end].strip()
    return first if len(first) <= 90 else first[:87].rstrip() + "..."


def type_spec(tp: Any) -> dict[str, Any]:
    """A JSON-able description of a config field type (inverse: :func:`type_from_spec`)."""
    origin = get_origin(tp)
    if tp in (int, float, bool, str):
        return {"kind": tp.__name__}
    if origin is Literal:
        return {"kind": "literal", "values": list(get_args(tp))}
    if origin in (types.UnionType, typing.Union):
        args = [a for a in get_args(tp) if a is not type(None)]
        inner = [type_spec(a) for a in args]
        spec = inner[0] if len(inner) == 1 else {"kind": "union", "of": inner}
        if type(None) in get_args(tp):
            return {"kind": "optional", "of": spec}
        return spec
    if origin in (tuple, list):
        args = get_args(tp)
        if not args or args[-1] is Ellipsis:
            return {"kind": "tuple", "of": type_spec(args[0]) if args else {"kind": "any"}}
        return {"kind": "tuple", "items": [type_spec(a) for a in args]}
    if dataclasses.is_dataclass(tp):
        return {"kind": "section", "name": tp.__name__}
    return {"kind": "any"}


def type_from_spec(spec: Mapping[str, Any], sections: Mapping[str, type] | None = None) -> Any:
    """The type described by :func:`type_spec` (sections looked up in ``sections``)."""
    kind = spec["kind"]
    if kind in ("int", "float", "bool", "str"):
        return {"int": int, "float": float, "bool": bool, "str": str}[kind]
    if kind == "literal":
        return Literal[tuple(spec["values"])]  # type: ignore[misc]
    if kind == "optional":
        return type_from_spec(spec["of"], sections) | None
    if kind == "union":
        out = None
        for s in spec["of"]:
            t = type_from_spec(s, sections)
            out = t if out is None else out | t
        return out
    if kind == "tuple":
        if "items" in spec:
            return tuple[tuple(type_from_spec(s, sections) for s in spec["items"])]  # type: ignore[misc]
        return tuple[type_from_spec(spec["of"], sections), ...]
    if kind == "section":
        return (sections or {})[spec["name"]]
    return Any


def describe(cls: type, prefix: str = "") -> list[dict[str, Any]]:
    """Every field of config class ``cls`` as a dict: ``key`` (dotted for sections),
    ``type`` (:func:`type_spec`), ``type_text``, ``default``, ``unit`` (``""`` when
    none is stated, ``"1"`` for a fraction), ``meaning``; a nested section gives a row
    of kind ``section`` followed by its own fields."""
    hints = typing.get_type_hints(cls)
    docs = _field_docs(cls)
    defaults = to_dict(cls())
    rows: list[dict[str, Any]] = []
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        tp = hints[f.name]
        spec = type_spec(tp)
        text = docs.get(f.name, "")
        if spec["kind"] == "section":
            rows.append({"key": prefix + f.name, "type": spec, "type_text": "a table",
                         "default": None, "unit": "", "meaning": _meaning(text) or (
                             _meaning((inspect.getdoc(tp) or "").split("\n\n")[0]))})  # fmt: skip
            rows.extend(describe(tp, prefix + f.name + "."))
            continue
        kind = spec["kind"] if spec["kind"] != "optional" else spec["of"]["kind"]
        rows.append({
            "key": prefix + f.name,
            "type": spec,
            "type_text": _type_name(tp),
            "default": defaults.get(f.name),
            "unit": _unit_of(f.name, kind, text),
            "meaning": _meaning(text),
        })  # fmt: skip
    return rows


def standin(rows: Sequence[Mapping[str, Any]], name: str = "Params") -> type:
    """A config class with the fields of :func:`describe`'s ``rows`` and no range checks:
    :func:`from_mapping` on it raises the same unknown-key and type errors as on the
    class described, without importing that class's module."""
    top: list[tuple[str, Any, Any]] = []
    nested: dict[str, list[Mapping[str, Any]]] = {}
    for r in rows:
        head, _, rest = r["key"].partition(".")
        if rest:
            nested.setdefault(head, []).append({**r, "key": rest})
    sections = {}
    for r in rows:
        key = r["key"]
        if "." in key:
            continue
        if r["type"]["kind"] == "section":
            sec = standin(nested.get(key, []), r["type"]["name"])
            sections[r["type"]["name"]] = sec
            top.append((key, sec, dataclasses.field(default=None)))
        else:
            top.append((key, type_from_spec(r["type"], sections), dataclasses.field(default=None)))
    return dataclasses.make_dataclass(name, top, frozen=True)
