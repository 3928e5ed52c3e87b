"""Fuzzing of the napari plugin's readers (every new reader is fuzzed, docs/robustness.md): a mutated file of
a format the plugin reads is a user error (DvrError, one line) or valid napari layer data, never another
exception, never a print, never a hang.

The plugin reads through dvr-gl's readers (fuzzed in ``tests/io/test_fuzz_readers.py``); what is new here is
its own step from a field to layers (scale, translate or affine, one layer per channel), which must never turn
a file dvr-gl accepted into an exception napari would show as a traceback, or into non-finite geometry.
napari itself is not needed: the readers import none of it.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from dvr_gl.errors import DvrError  # noqa: E402
from dvr_gl.napari.readers import get_reader  # noqa: E402
from dvr_gl.sandbox import Sandbox, active  # noqa: E402
from fuzz_inputs import BUDGET, TIMEOUT, mutate, seeds, time_limit, write_case  # noqa: E402

pytest.importorskip("nrrd")
pytest.importorskip("nibabel")

# the seeds of formats the plugin offers to read (its get_reader takes the main file)
SEEDS = [s for s in seeds() if s.reader not in ("csv", "npz", "hdf5") and get_reader(s.main) is not None]
FUZZ = settings(max_examples=15, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _layers_or_user_error(path) -> str:
    printed = io.StringIO()
    reader = get_reader(str(path))
    assert reader is not None
    try:
        with active(Sandbox(max_bytes=BUDGET)), time_limit(TIMEOUT), \
                contextlib.redirect_stderr(printed), contextlib.redirect_stdout(printed):
            layers = reader(str(path))
    except DvrError as exc:
        assert str(exc) and "\n" not in str(exc)
        return "user error"
    finally:
        assert not printed.getvalue(), f"printed {printed.getvalue()[:200]!r}"
    assert layers
    for data, attributes, kind in layers:
        assert kind in ("image", "surface")
        if kind == "image":
            rgb = attributes.get("rgb", False)   # a colour volume: (z, y, x, 3) in [0, 1]
            assert np.asarray(data).ndim == 3 + rgb and np.asarray(data).size > 0
            assert not rgb or (np.asarray(data).shape[-1] == 3 and ((data >= 0) & (data <= 1)).all())
            for key in ("scale", "translate", "affine"):
                if key in attributes:
                    assert np.isfinite(np.asarray(attributes[key], dtype=np.float64)).all(), key
        else:
            assert np.isfinite(data[0]).all() and (data[1] >= 0).all() and (data[1] < len(data[0])).all()
    return "layers"


def test_the_fuzzed_formats_include_the_plugins_volume_formats():
    assert {s.reader for s in SEEDS} >= {"nrrd", "metaimage", "vti"}


@pytest.mark.parametrize("seed", SEEDS, ids=[f"{s.reader}-{s.main}-{i}" for i, s in enumerate(SEEDS)])
def test_seed_reads_as_layers(tmp_path, seed):
    if seed.options:   # e.g. a vector NRRD read as colour only when asked: napari's reader asks nothing
        assert _layers_or_user_error(write_case(tmp_path, seed, seed.files)) in ("layers", "user error")
        return
    assert _layers_or_user_error(write_case(tmp_path, seed, seed.files)) == "layers"


@pytest.mark.parametrize("seed", SEEDS, ids=[f"{s.reader}-{s.main}-{i}" for i, s in enumerate(SEEDS)])
@FUZZ
@given(rnd=st.randoms(use_true_random=False))
def test_mutated_input_is_a_user_error_or_layers(tmp_path, seed, rnd):
    files, _ = mutate(seed, rnd)
    _layers_or_user_error(write_case(tmp_path, seed, files))
