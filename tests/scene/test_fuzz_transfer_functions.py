"""Property-based fuzzing of the transfer-function files (issue 40): Slicer's ``.vp``, Slicer's presets
XML and ParaView's colour-map JSON, mutated byte by byte, token by token and in their nesting, are a user
error (one line) or a valid transfer function (finite, values strictly increasing, colour and alpha in
[0, 1]), printing nothing, within a time and memory budget.  Derandomized; a few seconds in all.
"""

from __future__ import annotations

import contextlib
import io
import json
import random
import re
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
# the imports below come after importorskip on purpose: hypothesis is optional (E402)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from dvr_gl.errors import DvrError  # noqa: E402
from dvr_gl.sandbox import Sandbox, active  # noqa: E402
from dvr_gl.transfer_function import from_property, read_transfer_function_file  # noqa: E402
from fuzz_inputs import BAD_TOKENS, mutate_bytes, time_limit  # noqa: E402

TIMEOUT = 5.0  # seconds per example: the files are a few hundred bytes
BUDGET = 64 << 20  # the sandbox's memory budget while fuzzing
FUZZ = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

VP = "1\n1\n0.9\n0.1\n0.2\n10\n8 -1000 0 100 0 300 0.5 2000 0.8\n4 0 1 255 1\n" \
     "16 -1000 0 0 0 100 0.8 0.4 0.2 300 1 1 1 2000 1 1 0.9\n"
XML = ('<?xml version="1.0" encoding="UTF-8"?>\n<MRML>\n  <VolumeProperty name="Bone" interpolation="1" shade="1" '
       'diffuse="0.9" ambient="0.1" specular="0.2" specularPower="10" scalarOpacity="8 -1000 0 100 0 300 0.5 '
       '2000 0.8" gradientOpacity="4 0 1 255 1" colorTransfer="16 -1000 0 0 0 100 0.8 0.4 0.2 300 1 1 1 2000 1 '
       '1 0.9"/>\n</MRML>\n')
JSON = json.dumps([{"Name": "Cool to Warm", "ColorSpace": "Diverging",
                    "RGBPoints": [0, 0.23, 0.3, 0.75, 0.5, 0.86, 0.86, 0.86, 1, 0.7, 0.015, 0.15],
                    "Points": [0, 0, 0.5, 0, 1, 0.8, 0.5, 0]}], indent=1)
SEEDS = {"bone.vp": VP.encode(), "presets.xml": XML.encode(), "map.json": JSON.encode()}
# Tokens for numbers: the project's bad header values and what breaks ordering, counts and ranges.
TOKENS = BAD_TOKENS + ["1e38", "3.5e38", "-3.5e38", "1e-45", "1e309", "NaN", "Infinity", "-Infinity", "0.5", "2",
                       "300", "-1000", "0 0", "1 1 1 1"]


def mutate_tokens(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """A number replaced by a bad token, or a number duplicated, dropped or swapped with another
    (unsorted, duplicate and miscounted points)."""
    found = list(re.finditer(rb"-?[0-9][0-9.e+-]*", blob))
    if not found:
        return mutate_bytes(blob, rnd)
    m = rnd.choice(found)
    kind = rnd.choice(["token", "token", "duplicate", "drop", "swap"])
    if kind == "token":
        new = rnd.choice(TOKENS).encode("utf-8")
    elif kind == "duplicate":
        new = m.group(0) + (b", " if blob.lstrip().startswith(b"[") else b" ") + m.group(0)
    elif kind == "drop":
        new = b""
    else:
        new = rnd.choice(found).group(0)
    return blob[:m.start()] + new + blob[m.end():], f"{kind} at {m.start()}"


def mutate_nesting(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    """Brackets or elements wrapped around a part, many levels deep, or an entity declaration added."""
    depth = rnd.choice([2, 30, 1000, 100_000])
    opening = [m.start() for m in re.finditer(rb"[\[{]", blob)]
    if blob.lstrip().startswith(b"[") and opening:  # JSON
        at = rnd.choice(opening)
        close = blob.find(b"]", at)
        end = close + 1 if blob[at:at + 1] == b"[" and close >= 0 else len(blob)
        return blob[:at] + b"[" * depth + blob[at:end] + b"]" * depth + blob[end:], f"{depth} levels of []"
    if blob.lstrip().startswith(b"<"):  # XML
        if rnd.random() < 0.3:
            decl = b'<!DOCTYPE MRML [<!ENTITY a "' + b"x" * 10 + b'"><!ENTITY b "&a;&a;&a;&a;&a;">]>\n'
            return blob.replace(b"<MRML>", decl + b"<MRML>", 1), "an entity declaration"
        return blob.replace(b"<MRML>", b"<MRML>" + b"<g>" * depth, 1).replace(b"</MRML>", b"</g>" * depth + b"</MRML>",
                                                                              1), f"{depth} levels of elements"
    lines = blob.split(b"\n")  # .vp: a line repeated
    i = rnd.randrange(len(lines))
    return b"\n".join(lines[:i] + [lines[i]] * min(depth, 50) + lines[i + 1:]), f"line {i} repeated"


def mutate(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    return rnd.choice([mutate_tokens, mutate_tokens, mutate_bytes, mutate_nesting])(blob, rnd)


def check_transfer_function(path) -> str:
    """``user error`` or ``transfer function``; any other exception (or a hang) propagates."""
    printed = io.StringIO()
    try:
        with active(Sandbox(max_bytes=BUDGET)), time_limit(TIMEOUT), warnings.catch_warnings(), \
                contextlib.redirect_stderr(printed), contextlib.redirect_stdout(printed):
            warnings.simplefilter("ignore", UserWarning)  # what the file holds that we do not model: by design
            warnings.simplefilter("error", RuntimeWarning)  # numpy's overflow or invalid value: a finding
            prop = read_transfer_function_file(path)
            tf = from_property(prop, (-50.0, 2500.0), -1024.0)
    except DvrError as exc:
        message = str(exc)
        assert message and "\n" not in message
        return "user error"
    finally:
        assert not printed.getvalue(), f"printed {printed.getvalue()[:200]!r}"
    p = tf.points
    assert np.isfinite(p).all() and np.all(np.diff(p[:, 0]) > 0)
    assert ((p[:, 1:5] >= 0) & (p[:, 1:5] <= 1)).all()
    return "transfer function"


@pytest.mark.parametrize("name", sorted(SEEDS))
def test_seed_is_a_valid_transfer_function(tmp_path, name):
    (tmp_path / name).write_bytes(SEEDS[name])
    assert check_transfer_function(tmp_path / name) == "transfer function"


@pytest.mark.parametrize("name", sorted(SEEDS))
def test_mutated_file_is_a_user_error_or_a_transfer_function(tmp_path, name):
    seen = set()

    @FUZZ
    @given(rnd=st.randoms(use_true_random=False))
    def run(rnd):
        blob, what = mutate(SEEDS[name], rnd)
        (tmp_path / name).write_bytes(blob)
        try:
            seen.add(check_transfer_function(tmp_path / name))
        except Exception as exc:
            raise AssertionError(f"{name}, {what}: {type(exc).__name__}: {exc}") from exc

    run()
    # the mutations reach the checks (both outcomes come up in a run of this file; the draws may differ
    # after other test files in the process, so only the refusals are required)
    assert "user error" in seen
