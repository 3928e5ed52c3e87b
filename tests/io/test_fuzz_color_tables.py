"""Property-based fuzzing of the colour tables of label maps (Slicer .ctbl/.txt, ITK-SNAP, .seg.nrrd segment
metadata): a mutated table is a user error (one line) or a valid table (distinct integer labels, colour and
opacity in [0, 1]), printing nothing, within a time and memory budget.  Derandomized; a few seconds."""

from __future__ import annotations

import pytest

hypothesis = pytest.importorskip("hypothesis")
# the imports below come after importorskip on purpose: hypothesis is optional (E402)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from fuzz_inputs import COLOR_TABLES, check_color_table, mutate_color_table  # noqa: E402

FUZZ = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.mark.parametrize("name", sorted(COLOR_TABLES))
def test_seed_is_a_valid_table(tmp_path, name):
    (tmp_path / name).write_bytes(COLOR_TABLES[name])
    assert check_color_table(tmp_path / name) == "table"


@pytest.mark.parametrize("name", sorted(COLOR_TABLES))
def test_mutated_table_is_a_user_error_or_a_table(tmp_path, name):
    seen = set()

    @FUZZ
    @given(rnd=st.randoms(use_true_random=False))
    def run(rnd):
        blob, what = mutate_color_table(COLOR_TABLES[name], rnd)
        (tmp_path / name).write_bytes(blob)
        try:
            seen.add(check_color_table(tmp_path / name))
        except Exception as exc:
            raise AssertionError(f"{name}, {what}: {type(exc).__name__}: {exc}") from exc

    run()
    assert "user error" in seen  # the mutations reach the checks
