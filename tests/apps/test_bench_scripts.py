"""The one-off scripts (``benchmarks/`` and each renderer's ``benchmarks/``) still compile, import and parse
their flags, and ``benchmarks/README.md`` lists every one of them; they are run by hand, so nothing else
notices when a move breaks them."""

from __future__ import annotations

import ast
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


#: Run in one fresh process: numpy and dvr_gl imported once, then each script ``--help`` in a forked copy of
#: it (its own process, as from the shell: the script's folder first on sys.path, ``__main__``), its exit
#: status and output written back.  A fresh interpreter per script paid the same imports 29 times.
_FORKED_HELP = """
import os, runpy, sys, traceback
import numpy, dvr_gl
children = []
for path in sys.argv[1:]:
    read, write = os.pipe()
    sys.stdout.flush(); sys.stderr.flush()
    pid = os.fork()
    if pid == 0:
        os.close(read); os.dup2(write, 1); os.dup2(write, 2)
        sys.argv, sys.path[0], code = [path, "--help"], os.path.dirname(path), 0
        try:
            runpy.run_path(path, run_name="__main__")
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (exc.code is not None)
        except BaseException:
            traceback.print_exc(); code = 1
        sys.stdout.flush(); sys.stderr.flush()
        os._exit(code)
    os.close(write)
    children.append((path, pid, read))
for path, pid, read in children:
    with os.fdopen(read) as fh:
        out = fh.read()
    status = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
    print(repr((path, status, out)))
"""


def test_every_script_compiles_and_answers_help(tmp_path):
    """``--help`` imports what the script imports at its top and parses its flags (each script in a process of
    its own, forked from one that imported numpy and dvr_gl: _FORKED_HELP)."""
    for path in SCRIPTS:
        py_compile.compile(str(path), cfile=str(tmp_path / f"{path.stem}.pyc"), doraise=True)
    done = subprocess.run([sys.executable, "-c", _FORKED_HELP, *map(str, SCRIPTS)], cwd=REPO, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    answers = [ast.literal_eval(line) for line in done.stdout.splitlines()]
    assert [Path(a[0]) for a in answers] == SCRIPTS, done.stdout[-2000:]
    failed = [f"{Path(path).relative_to(REPO)}: exit {code}: {out[-400:]}" for path, code, out in answers
              if code != 0 or not out.startswith("usage:")]
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

