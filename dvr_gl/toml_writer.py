"""Writing TOML: tomli-w, with numpy's values made plain and a comment header; reading it (:func:`loads_toml`)
with nesting too deep for Python refused in one line.

The standard library reads TOML (``tomllib``) but does not write it; tomli-w is the well-kept writer
that pairs with it.  tomli-w writes floats with ``str``, which round-trips exactly, so a saved
scene reproduces the same numbers bit for bit.  It refuses numpy scalars other than ``float64``
(``int64``, ``float32``, ``bool_``) and arrays, which scenes and transfer functions carry, so those
are turned into Python numbers and lists first.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping

import numpy as np
import tomli_w

from .errors import SceneError


def plain(value):
    """``value`` with numpy scalars as Python numbers, arrays and tuples as lists (recursively)."""
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def dumps(data: dict, header: str = "") -> str:
    """TOML text for a nested dict (None values must be removed beforehand: TOML has no null),
    each line of ``header`` as a comment above it."""
    lines = "".join(f"# {ln}\n" for ln in header.splitlines()) + ("\n" if header else "")
    return lines + tomli_w.dumps(plain(data), indent=4)


def loads_toml(text: str, what: str) -> dict:
    """``tomllib.loads(text)``, with arrays or tables nested too deeply for Python's recursion (``x = [[[[...``
    a thousand deep) refused in one line naming ``what``, not escaping as a RecursionError (an internal
    error).  A malformed text raises :class:`tomllib.TOMLDecodeError` as before, for the caller to word."""
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise SceneError(f"{what}: arrays or tables nested too deeply; no setting nests more than a few "
                         f"levels, check the brackets") from None
