"""A TOML writer for the scene schema (tables, arrays of tables, numbers, strings, arrays).

The standard library reads TOML (``tomllib``) but does not write it.  Scenes
need only this subset; floats are written with ``repr``, which round-trips
exactly, so a saved scene reproduces the same numbers bit for bit.
"""

from __future__ import annotations

import json
import math


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        # JSON string escapes are TOML basic-string escapes; DEL must be escaped in TOML too.
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _key(k: str) -> str:
    return k if k and all(c.isalnum() or c in "_-" for c in k) else _value(k)


def _is_table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _table(lines: list[str], path: list[str], table: dict):
    scalars = {k: v for k, v in table.items() if not isinstance(v, dict) and not _is_table_array(v)}
    if path and (scalars or not table):
        lines.append(f"[{'.'.join(map(_key, path))}]")
    for k, v in scalars.items():
        lines.append(f"{_key(k)} = {_value(v)}")
    if scalars:
        lines.append("")
    for k, v in table.items():
        if isinstance(v, dict):
            _table(lines, path + [k], v)
        elif _is_table_array(v):
            for item in v:
                lines.append(f"[[{'.'.join(map(_key, path + [k]))}]]")
                for ik, iv in item.items():
                    lines.append(f"{_key(ik)} = {_value(iv)}")
                lines.append("")


def dumps(data: dict, header: str = "") -> str:
    """TOML text for a nested dict (None values must be removed beforehand)."""
    lines = [f"# {ln}" for ln in header.splitlines()] + ([""] if header else [])
    _table(lines, [], data)
    return "\n".join(lines).rstrip("\n") + "\n"
