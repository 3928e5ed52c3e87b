"""A regular (non-editable) install finds its shaders (the common library and each renderer's own) and its CLI,
and installs no test folder."""

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
    assert sorted(p.name for p in target.iterdir() if not p.name.endswith(".dist-info")) == ["bin", "dvr_gl"]
    assert (target / "dvr_gl" / "apps" / "cli.py").is_file()
    assert (target / "dvr_gl" / "gl" / "shaders" / "common" / "pixel.glsl").is_file()
    shaders = list((REPO / "dvr_gl" / "renderers").glob("*/shaders/**/*.*"))
    assert shaders  # each renderer's own shaders, in its folder, installed with it
    for path in shaders:
        assert (target / path.relative_to(REPO)).is_file(), path
    assert not list(target.rglob("test_*.py")), "the tests are not installed"
    assert (target / "dvr_gl" / "py.typed").is_file()  # type checkers read the package's annotations
    metadata = next(target.glob("dvr_gl-*.dist-info")) / "METADATA"
    assert "License-Expression: BSD-3-Clause" in metadata.read_text()
    assert (metadata.parent / "licenses" / "LICENSE").is_file()
    shutil.rmtree(src)  # nothing may come from the source tree any more
    check = ("import dvr_gl, dvr_gl.gl.shaders as s, dvr_gl.apps.cli; "
             "d = s.LIBRARY; print(d); "
             "assert str(d).startswith(%r), d; "
             "assert '#version' in s.load_shader('selftest.frag', {'SELFTEST_VALUE': '1.0'}).text" % str(target))
    proc = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, cwd=tmp_path,
                          env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 0, proc.stderr
