"""The end-to-end campaign (``benchmarks/fuzz_campaign.py``) keeps working, and its sandbox escapes are
refused by the real command: a fresh ``dvr`` process per case, as an attacker would run it.

Only a sample runs here (each case is a process start, about a second); the whole campaign is a bench:
``python benchmarks/fuzz_campaign.py --examples 300``.
"""

from __future__ import annotations

import importlib.util
import random
from pathlib import Path

import pytest

pytest.importorskip("zarr")
pytest.importorskip("h5py")
pytest.importorskip("pydicom")

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "fuzz_campaign.py"


@pytest.fixture(scope="module")
def campaign():
    spec = importlib.util.spec_from_file_location("fuzz_campaign", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _folders(tmp_path):
    serial = iter(range(10**6))

    def make(name):
        base = tmp_path / f"case{next(serial)}"
        (base / "root").mkdir(parents=True)
        (base / "outside").mkdir()
        return base / "root", base / "outside"
    return make


# one escape of each kind of link: a zarr chunk, an OME path, HDF5's three, a DICOM member, a scene path
SAMPLE = ("zarr chunk linked out", "OME dataset path with ..", "HDF5 external link", "HDF5 virtual dataset",
          "HDF5 external storage", "DICOM member linked out", "scene volume.path with ..")


def test_every_escape_is_built(campaign, tmp_path):
    """Each escape case names a file that reaches outside its root (a link, a ``..`` or an absolute path)."""
    cases = campaign.escape_cases(_folders(tmp_path))
    assert {c.name for c in cases} >= set(SAMPLE)
    assert all(c.must_refuse and "--sandbox" in c.args for c in cases)


@pytest.mark.parametrize("name", SAMPLE)
def test_escape_is_refused_by_the_command(campaign, tmp_path, name):
    case = next(c for c in campaign.escape_cases(_folders(tmp_path)) if c.name == name)
    verdict, _, stderr = campaign.run_case(case, timeout=120)
    assert verdict == "ok: refused", (verdict, stderr)


def test_mutated_and_settings_cases_are_judged(campaign, tmp_path):
    """A few drawn cases run to a verdict (the judge itself: a finding would be a bug to fix)."""
    rnd = random.Random(3)
    make = _folders(tmp_path)
    cases = [campaign.mutated_case(make("")[0], kind, rnd) for kind in ("ome-zarr 0.5", "vtu", "slicer vp")]
    cases.append(campaign.settings_case(make("")[0], rnd))
    for case in cases:
        verdict, _, stderr = campaign.run_case(case, timeout=120)
        assert verdict.startswith("ok"), (case.name, verdict, stderr)
