"""TOML text of a vehicle file's values: writing them (``tomllib`` only reads) and naming them in messages."""

from __future__ import annotations

import re
from collections.abc import Mapping

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def toml_string(s: str) -> str:
    out = []
    for ch in s:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(k: str) -> str:
    return k if _BARE_KEY.match(k) else toml_string(k)


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)  # shortest exact repr; inf, -inf, nan are TOML too
    if isinstance(v, str):
        return toml_string(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    # numpy scalars and the like
    if hasattr(v, "item"):
        return toml_value(v.item())
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def toml_type(v) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, list):
        return "an array"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, (int, float)):
        return "a number"
    return type(v).__name__


def is_scalar(v) -> bool:
    return isinstance(v, (bool, int, float, str))


def fmt_value(value) -> str:
    """A value as it would be written in the file (for messages)."""
    try:
        return toml_value(value)
    except TypeError:
        return repr(value)


def fmt_options(options: Mapping) -> str:
    return "{" + ", ".join(f"{k} = {fmt_value(v)}" for k, v in options.items()) + "}"
