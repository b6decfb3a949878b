"""TOML text of a vehicle file's values: writing them (``tomllib`` only reads) and naming them in messages."""

from __future__ import annotations

import re
from collections.abc import Mapping

__all__ = ["toml_string", "toml_key", "toml_value", "toml_type", "is_scalar", "fmt_value", "fmt_options"]

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def toml_string(s: str) -> str:
    """A TOML basic string (quoted, with escapes)."""
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
    """A TOML key: bare where it may be, else quoted."""
    return k if _BARE_KEY.match(k) else toml_string(k)


def toml_value(v) -> str:
    """A TOML value (boolean, integer, float by its exact ``repr``, string, array); TypeError for others."""
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
    """What a value read from TOML is, for messages ("a table", "a string", ...)."""
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
    """Whether ``v`` is a TOML scalar (boolean, number, string)."""
    return isinstance(v, (bool, int, float, str))


def fmt_value(value) -> str:
    """A value as it would be written in the file (for messages)."""
    try:
        return toml_value(value)
    except TypeError:
        return repr(value)


def fmt_options(options: Mapping) -> str:
    """A table of options as an inline TOML table (for messages)."""
    return "{" + ", ".join(f"{k} = {fmt_value(v)}" for k, v in options.items()) + "}"
