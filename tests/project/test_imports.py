"""The module graph of dvr_gl has no cycle and follows the documented layering (tests/project/layers.toml).

Every import of every module under ``dvr_gl/`` is read with :mod:`ast`: at module level and inside
functions (a function-level import still makes the importer depend on the imported, it only defers
the failure), ``if TYPE_CHECKING`` ones too; relative imports resolved; ``from X import name`` goes to
the submodule ``X.name`` when there is one, else to ``X``.  Only imports of dvr_gl's own modules count.

A package's ``__init__`` is a module of its own, the package's name: ``import dvr_gl.fields.grid``
is an edge to ``dvr_gl.fields.grid``, not to ``dvr_gl`` and ``dvr_gl.fields`` whose ``__init__`` Python
runs first.  That implicit step is left out because it is no dependency of the importer: Python puts a
package in ``sys.modules`` before its ``__init__`` runs, so importing a submodule of a package whose
``__init__`` is still running succeeds; what a cycle breaks is a *name* taken from a half-run module, and
that is always an explicit ``from X import name``, counted here (``from dvr_gl import render`` from
inside the package is an edge to the facade ``dvr_gl``, at the api layer, and fails as upward).  Counting
it would make every package that re-exports its submodules a cycle, and the facade ``dvr_gl/__init__.py``
(which imports the API so that ``dvr_gl.render`` works) a cycle through every module.

The tests inside a renderer's folder (``dvr_gl/renderers/NAME/tests``) are left out: they are tests,
above everything, and nothing imports them.
"""

from __future__ import annotations

import ast
import tomllib
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "dvr_gl"
LAYERS_FILE = Path(__file__).with_name("layers.toml")


def modules() -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its own name, for its ``__init__``)."""
    out = {}
    for path in sorted((ROOT / PACKAGE).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if "tests" in parts:
            continue
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


@dataclass(frozen=True)
class Import:
    importer: str
    imported: str
    line: int

    def __str__(self) -> str:
        return f"{self.importer} -> {self.imported} (line {self.line})"


def _known(name: str, known) -> str | None:
    """The longest prefix of dotted ``name`` that is a module of the package (None outside it)."""
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def imports_of(module: str, path: Path, known) -> list[Import]:
    """Every import of the package's modules in ``module`` (any depth of the syntax tree)."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [_known(alias.name, known) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else _known(base, known)
                       for alias in node.names]
        else:
            continue
        out += [Import(module, t, node.lineno) for t in targets if t and t != module]
    return out


def graph() -> dict[str, list[Import]]:
    known = modules()
    return {m: imports_of(m, path, known) for m, path in known.items()}


def cycles(edges: dict[str, list[Import]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    succ = {m: sorted({i.imported for i in imps}) for m, imps in edges.items()}
    index, low, on_stack, stack, found = {}, {}, set(), [], []
    for root in succ:
        if root in index:
            continue
        work = [(root, iter(succ[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(succ.get(child, ()))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


@dataclass(frozen=True)
class Layers:
    """The layering read from layers.toml: ``entries`` maps a pattern (dotted, relative to the package,
    ``*`` for one name) to its layer's rank, bottom 0; ``names`` the layers' names by rank."""

    entries: dict[tuple[str, ...], int]
    names: list[str]

    @classmethod
    def read(cls, path: Path = LAYERS_FILE) -> "Layers":
        table = tomllib.loads(path.read_text())["layer"]
        entries = {}
        for rank, layer in enumerate(table):
            for entry in layer["modules"]:
                pattern = tuple(entry.split(".")) if entry != PACKAGE else ()
                assert pattern not in entries, f"{entry} is listed twice in {path.name}"
                entries[pattern] = rank
        return cls(entries, [layer["name"] for layer in table])

    def rank(self, module: str) -> int | None:
        """The layer of ``module`` (dotted, with the package's name): its longest matching entry's, an
        exact name before a ``*`` of the same length; None if no entry matches."""
        parts = tuple(module.split("."))[1:]
        best = None
        for pattern, rank in self.entries.items():
            if len(pattern) <= len(parts) and all(p in ("*", q) for p, q in zip(pattern, parts)):
                key = (len(pattern), -pattern.count("*"))
                if best is None or key > best[0]:
                    best = (key, rank)
        return None if best is None else best[1]


def upward(edges: dict[str, list[Import]], layers: Layers) -> list[str]:
    out = []
    for imps in edges.values():
        for i in imps:
            low, high = layers.rank(i.importer), layers.rank(i.imported)
            if low is not None and high is not None and high > low:
                out.append(f"{i}: {layers.names[low]} imports {layers.names[high]}")
    return out


def test_the_module_graph_has_no_cycle():
    found = cycles(graph())
    assert not found, "import cycles (function-level imports counted):\n" + "\n".join(
        " <-> ".join(c) for c in found)


def test_every_module_has_a_layer():
    layers = Layers.read()
    assert [m for m in modules() if layers.rank(m) is None] == []


def test_every_entry_of_the_layering_places_a_module():
    """A module moved or removed leaves no entry behind that would place a later module of that name."""
    layers, names = Layers.read(), modules()
    unused = []
    for pattern in layers.entries:
        single = Layers({pattern: 0}, ["one"])
        if not any(single.rank(m) is not None for m in names):
            unused.append(".".join(pattern) or PACKAGE)
    assert unused == []


def test_no_import_goes_up_the_layers():
    found = upward(graph(), Layers.read())
    assert not found, "imports against tests/project/layers.toml:\n" + "\n".join(found)


def test_the_checker_sees_what_it_must(tmp_path):
    """The reader and the checks on a made-up package: a function-level relative import closing a cycle,
    ``from . import name`` resolving to the submodule, an upward import."""
    known = {"p": tmp_path / "__init__.py", "p.low": tmp_path / "low.py", "p.high": tmp_path / "high.py",
             "p.sub": tmp_path / "sub" / "__init__.py", "p.sub.leaf": tmp_path / "sub" / "leaf.py"}
    (tmp_path / "sub").mkdir()
    texts = {"p": "from .high import api\n", "p.low": "def f():\n    from .high import thing\n",
             "p.high": "import os\nfrom . import low\n", "p.sub": "from . import leaf\n",
             "p.sub.leaf": "from .. import low\nfrom ..sub import leaf as again\n"}
    for name, text in texts.items():
        known[name].write_text(text)
    edges = {m: imports_of(m, path, known) for m, path in known.items()}
    assert {m: sorted({i.imported for i in imps}) for m, imps in edges.items()} == {
        "p": ["p.high"], "p.low": ["p.high"], "p.high": ["p.low"], "p.sub": ["p.sub.leaf"], "p.sub.leaf": ["p.low"]}
    assert cycles(edges) == [["p.high", "p.low"]]
    layers = Layers({("low",): 0, ("sub",): 1, ("sub", "leaf"): 0, ("*", "leaf"): 1, ("high",): 1, (): 1},
                    ["bottom", "top"])
    assert [layers.rank(m) for m in ("p.sub.leaf", "p.sub", "p.high", "p", "q")] == [0, 1, 1, 1, 1]
    assert Layers({("*",): 0}, ["any"]).rank("p.x.y") == 0 and Layers({("x",): 0}, ["x"]).rank("p.y") is None
    assert upward(edges, layers) == ["p.low -> p.high (line 2): bottom imports top"]
