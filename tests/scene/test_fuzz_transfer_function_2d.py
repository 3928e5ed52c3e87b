"""Property-based fuzzing of ParaView state files read for their 2D transfer function (``.pvsm``): attribute values
replaced by bad tokens, bytes changed, elements nested deep or an entity declaration added are a user error (one
line) or a valid 2D transfer function (finite, colour and alpha in [0, 1]), printing nothing, within a time and
memory budget.  Derandomized; a few seconds."""

from __future__ import annotations

import contextlib
import io
import random
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
# the imports below come after importorskip on purpose: hypothesis is optional (E402)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from dvr_gl.errors import DvrError  # noqa: E402
from dvr_gl.sandbox import Sandbox, active  # noqa: E402
from dvr_gl.transfer_function_2d import TransferFunction2D, read_paraview_state  # noqa: E402
from fuzz_inputs import mutate_bytes, mutate_xml, time_limit  # noqa: E402

FUZZ = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
BOXES = [0.1, 0.0, 0.4, 2.0, 1.0, 0.5, 0.2, 0.8, 0.3, 1.0, 0.5, 3.0, 0.2, 0.4, 1.0, 0.5]
SEED = ('<ParaView>\n  <ServerManagerState version="5.11.0">\n'
        '    <Proxy group="transfer_2d_functions" type="TransferFunction2D" id="7" servers="21">\n'
        '      <Property name="Boxes" id="7.Boxes" number_of_elements="16">\n'
        + "".join(f'        <Element index="{i}" value="{v}"/>\n' for i, v in enumerate(BOXES)) +
        '      </Property>\n      <Property name="Range" id="7.Range" number_of_elements="4">\n'
        + "".join(f'        <Element index="{i}" value="{v}"/>\n' for i, v in enumerate([0, 1, 0, 4])) +
        '      </Property>\n    </Proxy>\n  </ServerManagerState>\n</ParaView>\n').encode()


def mutate(blob: bytes, rnd: random.Random) -> tuple[bytes, str]:
    kind = rnd.choice(["xml", "xml", "xml", "bytes", "nesting", "entity"])
    if kind == "xml":
        return mutate_xml(blob, rnd)
    if kind == "bytes":
        return mutate_bytes(blob, rnd)
    if kind == "entity":
        decl = b'<!DOCTYPE ParaView [<!ENTITY a "xxxxxxxxxx"><!ENTITY b "&a;&a;&a;&a;">]>\n'
        return decl + blob, "an entity declaration"
    depth = rnd.choice([2, 1000, 100_000])
    return blob.replace(b"<ParaView>", b"<ParaView>" + b"<g>" * depth, 1).replace(
        b"</ParaView>", b"</g>" * depth + b"</ParaView>", 1), f"{depth} levels of elements"


def check_state(path) -> str:
    """``user error`` or ``transfer function``; any other exception (or a hang) propagates."""
    printed = io.StringIO()
    try:
        with active(Sandbox(max_bytes=64 << 20)), time_limit(5.0), contextlib.redirect_stderr(printed), \
                contextlib.redirect_stdout(printed), warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # numpy's overflow or invalid value: a finding
            boxes, ranges = read_paraview_state(path)
            tf = TransferFunction2D.from_boxes(boxes, ranges[:2] if ranges else (0, 1), ranges[2:] if ranges
                                               else (0, 4), size=(16, 8))
    except DvrError as exc:
        assert str(exc) and "\n" not in str(exc)
        return "user error"
    finally:
        assert not printed.getvalue(), f"printed {printed.getvalue()[:200]!r}"
    t = tf.table
    assert np.isfinite(t).all() and ((t >= 0) & (t <= 1)).all()
    return "transfer function"


def test_the_seed_is_a_2d_transfer_function(tmp_path):
    (tmp_path / "s.pvsm").write_bytes(SEED)
    assert check_state(tmp_path / "s.pvsm") == "transfer function"


def test_a_mutated_state_is_a_user_error_or_a_2d_transfer_function(tmp_path):
    seen = set()

    @FUZZ
    @given(rnd=st.randoms(use_true_random=False))
    def run(rnd):
        blob, what = mutate(SEED, rnd)
        (tmp_path / "s.pvsm").write_bytes(blob)
        try:
            seen.add(check_state(tmp_path / "s.pvsm"))
        except Exception as exc:
            raise AssertionError(f"{what}: {type(exc).__name__}: {exc}") from exc

    run()
    assert seen == {"user error", "transfer function"}
