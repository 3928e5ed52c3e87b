"""The one-off scripts (``benchmarks/`` and each renderer's ``benchmarks/``) still compile, import and parse
their flags, and ``benchmarks/README.md`` lists every one of them; they are run by hand, so nothing else
notices when a move breaks them."""

from __future__ import annotations

import py_compile
import runpy
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SCRIPTS = sorted([*REPO.glob("benchmarks/*.py"), *REPO.glob("dvr_gl/renderers/*/benchmarks/*.py")])


def test_the_scripts_are_found():
    names = {p.name for p in SCRIPTS}
    assert {"image_hashes.py", "gallery.py", "pt_floor.py", "defaults.py"} <= names and len(names) == len(SCRIPTS)


def test_every_script_compiles_and_answers_help(tmp_path):
    """``--help`` imports what the script imports at its top and parses its flags (in parallel: a few
    seconds each, most of it importing dvr_gl)."""
    for path in SCRIPTS:
        py_compile.compile(str(path), cfile=str(tmp_path / f"{path.stem}.pyc"), doraise=True)
    runs = {path: subprocess.Popen([sys.executable, str(path), "--help"], cwd=REPO, stdout=subprocess.PIPE,
                                   stderr=subprocess.STDOUT, text=True) for path in SCRIPTS}
    failed = []
    for path, run in runs.items():
        out, _ = run.communicate(timeout=300)
        if run.returncode != 0 or not out.startswith("usage:"):
            failed.append(f"{path.relative_to(REPO)}: exit {run.returncode}: {out[-400:]}")
    assert not failed, "\n".join(failed)


def test_the_readme_lists_every_script():
    readme = (REPO / "benchmarks" / "README.md").read_text()
    missing = [str(p.relative_to(REPO)) for p in SCRIPTS if str(p.relative_to(REPO)) not in readme]
    assert not missing, f"benchmarks/README.md does not list {missing}"


def test_pt_floor_cuts_the_renderers_own_fragment_shader(tmp_path):
    """pt_floor.py measures cut-down copies of projected tetrahedra's shader folder (it copied the old
    top-level shaders/ once): each variant's pt.frag differs from the shipped one, the other files do not."""
    script = next(p for p in SCRIPTS if p.name == "pt_floor.py")
    cut = runpy.run_path(str(script))["_shaders"]
    shipped = {p.name: p.read_text() for p in cut("shipped", tmp_path / "shipped").iterdir()}
    assert {"pt.vert", "pt.geom", "pt.frag"} <= set(shipped)
    for variant in ("no integral", "flat"):
        root = cut(variant, tmp_path / variant.replace(" ", "_"))
        changed = {p.name for p in root.iterdir() if p.read_text() != shipped[p.name]}
        assert changed == {"pt.frag"}, variant

