"""Property-based fuzzing of every volume reader (issue 14): a mutated file is a user error
(DvrError, one line) or a valid Volume, never another exception and never a hang.

The mutations are in ``fuzz_inputs.py``; hypothesis draws the random choices, derandomized so CI
is reproducible.  ``benchmarks/fuzz_readers.py`` runs the same mutations much longer.
"""

from __future__ import annotations

import pytest

hypothesis = pytest.importorskip("hypothesis")
# the imports below come after importorskip on purpose: hypothesis is optional (E402)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from fuzz_inputs import check_reader, mutate, seeds, shared_seeds, write_case  # noqa: E402

pytest.importorskip("nrrd")
pytest.importorskip("nibabel")

SEEDS = seeds()
# A few dozen examples per seed keeps all reader fuzzing to a few seconds; the long run
# (benchmarks/fuzz_readers.py) covers thousands.
FUZZ = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.mark.parametrize("seed", SEEDS, ids=[f"{s.reader}-{s.main}-{i}" for i, s in enumerate(SEEDS)])
def test_seed_is_a_valid_volume(tmp_path, seed):
    """The unmutated inputs load (so the mutations start from something that works)."""
    assert check_reader(write_case(tmp_path, seed, seed.files), seed) == "volume"


@pytest.mark.parametrize("seed", SEEDS, ids=[f"{s.reader}-{s.main}-{i}" for i, s in enumerate(SEEDS)])
@FUZZ
@given(rnd=st.randoms(use_true_random=False))
def test_mutated_input_is_a_user_error_or_a_volume(tmp_path, seed, rnd):
    files, _ = mutate(seed, rnd)
    check_reader(write_case(tmp_path, seed, files), seed)


def test_mutated_shared_headers(tmp_path, shared_data):
    """Mutations of the real headers in ../shared/data (their data files linked, not copied)."""
    found = shared_seeds(shared_data)
    assert found

    @settings(FUZZ, max_examples=60)
    @given(index=st.integers(0, len(found) - 1), rnd=st.randoms(use_true_random=False))
    def run(index, rnd):
        files, _ = mutate(found[index], rnd)
        check_reader(write_case(tmp_path, found[index], files), found[index])

    run()
