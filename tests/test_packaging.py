"""A regular (non-editable) install finds its shaders and its CLI, and installs no package 'apps'."""

import shutil
import subprocess
import sys

import pytest

from conftest import REPO


@pytest.mark.slow
def test_regular_install_finds_shaders(tmp_path):
    src = tmp_path / "src"
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns(".git", ".venv", "*.egg-info", "build",
                                                             "__pycache__", ".pytest_cache", "tests"))
    target = tmp_path / "site"
    pip = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                          "--target", str(target), str(src)], capture_output=True, text=True)
    assert pip.returncode == 0, pip.stderr[-2000:]
    assert not (target / "apps").exists()
    assert (target / "dvr_gl" / "apps" / "cli.py").is_file()
    assert (target / "dvr_gl" / "shaders" / "common" / "pixel.glsl").is_file()
    assert (target / "dvr_gl" / "py.typed").is_file()  # type checkers read the package's annotations
    metadata = next(target.glob("dvr_gl-*.dist-info")) / "METADATA"
    assert "License-Expression: BSD-3-Clause" in metadata.read_text()
    assert (metadata.parent / "licenses" / "LICENSE").is_file()
    shutil.rmtree(src)  # nothing may come from the source tree any more
    check = ("import dvr_gl, dvr_gl.gl.shaders as s, dvr_gl.apps.cli; "
             "d = s.shader_dir(); print(d); "
             "assert str(d).startswith(%r), d; "
             "assert '#version' in s.load_shader('selftest.frag', {'SELFTEST_VALUE': '1.0'}).text" % str(target))
    proc = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, cwd=tmp_path,
                          env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 0, proc.stderr


def test_every_package_is_listed_in_pyproject():
    """setuptools cannot discover packages here (apps/ and shaders/ install under dvr_gl), so
    pyproject.toml lists them: a package under dvr_gl/ missing from the list would be absent from a
    regular install.  (Renderers in other packages need no entry here: tests/test_plugins.py.)"""
    import tomllib

    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    on_disk = {".".join(p.parent.relative_to(REPO).parts) for p in (REPO / "dvr_gl").rglob("__init__.py")}
    missing = sorted(on_disk - listed)
    assert not missing, f"add {missing} to [tool.setuptools] packages in pyproject.toml"
    assert {"dvr_gl.apps", "dvr_gl.shaders"} <= listed
