"""A renderer is one folder: no Python file outside a registered renderer's own package names it.

Everything else asks the registry for declared traits (``dvr_gl.scene.plugin.RendererPlugin``), so
a third-party renderer is served by the same code.  Read with :mod:`ast` from every ``.py`` file of
the repository (the package, the tests, the benchmarks, ``conftest.py``):

* a string constant equal to a registered renderer's name, docstrings included;
* an import of a registered renderer's package or of a module in it, relative imports resolved;
* a string naming that package as a module or a path (``"dvr_gl.renderers.NAME.renderer"``,
  ``dvr_gl/renderers/NAME/shaders`` for a renderer whose package is ``NAME``), docstrings included.

The names and packages come from the registered entry points, so a renderer installed from another
distribution is covered too.  Docs pages that list the renderers and ``pyproject.toml``'s entry
points are not Python and are allowed by design.
"""

from __future__ import annotations

import ast
import importlib
import re
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

from dvr_gl.renderers import registry

ROOT = Path(__file__).resolve().parents[2]
#: What the rule covers: the package, the tests, the benchmark scripts and the root conftest.
SCANNED = ("dvr_gl", "tests", "benchmarks", "conftest.py")


@dataclass(frozen=True)
class Renderer:
    """A registered renderer: its ``name``, its ``package`` (dotted) and ``home`` (its folder, or its
    module file for a one-module plugin), where naming it is allowed."""

    name: str
    package: str
    home: Path

    def owns(self, path: Path) -> bool:
        return path == self.home or self.home in path.parents


def registered() -> list[Renderer]:
    """Every registered renderer that loads, from its entry point (``package:PLUGIN``)."""
    loaded = registry.plugins()
    out = []
    for ep in metadata.entry_points(group=registry.ENTRY_POINT_GROUP):
        if ep.name not in loaded or any(r.name == ep.name for r in out):
            continue
        module = importlib.import_module(ep.module)
        file = Path(module.__file__).resolve()
        home = file.parent if file.name == "__init__.py" else file
        out.append(Renderer(ep.name, ep.module, home))
    return out


def python_files() -> list[Path]:
    files = []
    for entry in SCANNED:
        path = ROOT / entry
        files += [path] if path.is_file() else sorted(p for p in path.rglob("*.py") if "__pycache__" not in p.parts)
    return files


def imported(node: ast.AST, package: list[str]) -> list[str]:
    """The absolute module names an import statement reaches, a relative one resolved from ``package``
    (the importing file's folder, as dotted parts from the repository root)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if not isinstance(node, ast.ImportFrom):
        return []
    if node.level:
        base = package
        base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
        module = ".".join(base + ([node.module] if node.module else []))
    else:
        module = node.module or ""
    return [module] + [f"{module}.{a.name}" for a in node.names]


def argument_names(tree: ast.AST) -> set[int]:
    """ids of the strings that name a test's parameters (``parametrize("reference", ...)``): identifiers,
    not data, whatever they happen to spell."""
    ids = set()
    for node in ast.walk(tree):
        func = getattr(node, "func", None)
        called = getattr(func, "attr", None) or getattr(func, "id", None)
        if called == "parametrize" and node.args and isinstance(node.args[0], ast.Constant):
            ids.add(id(node.args[0]))
    return ids


def package_pattern(r: Renderer) -> re.Pattern:
    """``r``'s package as a dotted module or a slashed path, followed by no more of a name."""
    parts = [re.escape(p) for p in r.package.split(".")]
    return re.compile(r"(?<![\w.])(?:" + r"\.".join(parts) + "|" + "/".join(parts) + r")(?![\w-])")


def findings(path: Path, renderers: list[Renderer], root: Path = ROOT) -> list[str]:
    """``line: what`` for every place ``path`` (in the repository at ``root``) names a renderer whose folder
    it is not in."""
    others = [r for r in renderers if not r.owns(path)]
    if not others:
        return []
    text = path.read_text(encoding="utf-8")
    tree = ast.parse(text, filename=str(path))
    by_name = {r.name: r for r in others}
    # (a package's pattern can only match a string that holds its last part: the cheap test first)
    patterns = [(r, package_pattern(r), r.package.rsplit(".", 1)[-1]) for r in others]
    skip = argument_names(tree) if "parametrize" in text else set()  # (a second walk only where it can find)
    package = list(path.relative_to(root).parent.parts)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):  # (the only nodes imported() reads)
            modules = imported(node, package)
            out += [f"{node.lineno}: imports {r.package} (renderer {r.name!r})" for r in others
                    if any(m == r.package or m.startswith(r.package + ".") for m in modules)]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            if node.value in by_name:
                out.append(f"{node.lineno}: the string {node.value!r} (a renderer's name)")
            for r, pattern, last in patterns:
                if last not in node.value:
                    continue
                for match in pattern.finditer(node.value):
                    line = node.lineno + node.value.count("\n", 0, match.start())  # the line in a docstring
                    out.append(f"{line}: a string naming {r.package} (renderer {r.name!r})")
    return sorted(set(out), key=lambda s: (int(s.split(":")[0]), s))


def test_the_rule_sees_every_kind_of_naming(tmp_path):
    """The finder itself: a name, an absolute and a relative import, a module path in a docstring and a
    file path are found; a parametrize argument, a longer word and another package are not."""
    r = Renderer("ray-thing", "pkg.renderers.ray_thing", tmp_path / "pkg" / "renderers" / "ray_thing")
    folder = tmp_path / "pkg" / "other"
    folder.mkdir(parents=True)
    source = folder / "user.py"
    source.write_text('"""See pkg.renderers.ray_thing.code\nand pkg/renderers/ray_thing/shaders."""\n'
                      "import pkg.renderers.ray_thing\n"
                      "from ..renderers.ray_thing import code\n"
                      "from ..renderers import ray_thing\n"
                      'NAME = "ray-thing"\n'
                      'OK = ("ray-things", "pkg.renderers.ray_thingy", "pkg.renderers.grid")\n'
                      '@parametrize("ray-thing", [1])\n'
                      "def f(): pass\n")
    found = findings(source, [r], root=tmp_path)
    assert [f.split(":")[0] for f in found] == ["1", "2", "3", "4", "5", "6"], found
    assert findings(r.home / "inside.py", [r]) == []


def test_the_renderers_are_found():
    """The rule reads the registry: every registered renderer, with its own folder."""
    renderers = registered()
    assert {r.name for r in renderers} == set(registry.names())
    for r in renderers:
        assert r.home.exists(), r


def test_no_module_outside_a_renderers_folder_names_it():
    renderers = registered()
    report = []
    for path in python_files():
        report += [f"{path.relative_to(ROOT)}:{f}" for f in findings(path, renderers)]
    assert not report, (f"{len(report)} places outside a renderer's folder name it (ask the registry for a "
                        f"declared trait instead):\n" + "\n".join(report))
