"""The two headless OpenGL backends, EGL and OSMesa (dvr_gl/gl/context.py, dvr_gl/gl/osmesa.py): how one is
chosen, what a missing one says, that OSMesa's images are EGL's, and that a subset of the conformance tests
passes under OSMesa.

One process uses one headless backend (both are Mesa and share its dispatch library), so whatever renders
through OSMesa here runs in a subprocess; this process renders through the backend the run chose (EGL unless
``DVR_GL_BACKEND`` says otherwise)."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from dvr_gl.errors import GLUnavailableError
from dvr_gl.gl import context, osmesa

ROOT = Path(__file__).resolve().parents[2]


def _env(**changes) -> dict:
    env = {k: v for k, v in os.environ.items() if k != context.BACKEND_VARIABLE}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(ROOT / "tests"), env.get("PYTHONPATH", "")])
    return {**env, **changes}


def gl_cases() -> list:
    """(renderer, closed form, mode, view) for each OpenGL renderer: the conformance suite's first closed-form
    case of it (the first form it renders, in the first mode it declares for that form, in its first view)."""
    from closed_forms import CLOSED_FORMS, VIEWS
    from dvr_gl.renderers import registry

    cases = []
    for name, plugin in registry.plugins().items():
        view = next((v for v in VIEWS if v in plugin.projections), None)
        for cf in CLOSED_FORMS.values() if plugin.needs_gl and view else ():
            modes = [m for m in cf.modes if m in plugin.choices("compositing")]
            if modes and (plugin.data_kinds is None or cf.kind in plugin.data_kinds):
                cases.append((name, cf.name, modes[0], view))
                break
    return cases


def render_cases(folder: Path) -> dict:
    """Each of :func:`gl_cases`' images (float32 RGBA), by ``renderer/form/mode/view``; scenes' files in ``folder``."""
    from closed_forms import CLOSED_FORMS
    from dvr_gl.renderers import create_renderer

    images, opened = {}, {}
    try:
        for name, form, mode, view in gl_cases():
            renderer = opened.setdefault(name, create_renderer(name))
            images[f"{name}/{form}/{mode}/{view}"] = renderer.render(CLOSED_FORMS[form].scene(folder, mode, view, name))
    finally:
        for r in opened.values():
            r.close()
    return images


def test_the_backend_is_the_variable_s(monkeypatch):
    monkeypatch.delenv(context.BACKEND_VARIABLE, raising=False)
    assert context.chosen_backend() == "auto"
    monkeypatch.setenv(context.BACKEND_VARIABLE, " OSMesa ")
    assert context.chosen_backend() == "osmesa"
    monkeypatch.setenv(context.BACKEND_VARIABLE, "vulkan")
    with pytest.raises(GLUnavailableError, match="DVR_GL_BACKEND='vulkan' is no OpenGL backend; use one of auto, egl"):
        context.chosen_backend()


def test_no_backend_at_all_names_both_packages(monkeypatch):
    """EGL's library and OSMesa's both missing: one line naming the Debian package of each."""
    monkeypatch.setattr(osmesa, "LIBRARIES", ("libOSMesa_does_not_exist.so.8",))
    osmesa.library.cache_clear()
    try:
        with pytest.raises(GLUnavailableError) as failure:
            context.create_context("auto", libegl="libEGL_does_not_exist.so.1")
    finally:
        osmesa.library.cache_clear()
    message = str(failure.value)
    assert "\n" not in message and "apt install libegl1" in message and "apt install libosmesa6" in message


def test_without_egl_info_falls_back_to_osmesa_and_says_so_once():
    env = _env(GLCONTEXT_LINUX_LIBEGL="/nonexistent/libEGL.so.1")
    proc = subprocess.run([sys.executable, "-m", "dvr_gl.apps", "info"], env=env, capture_output=True, text=True,
                          cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    assert "OpenGL backend:  osmesa" in proc.stdout and "llvmpipe" in proc.stdout
    said = [line for line in proc.stderr.splitlines() if "OSMesa" in line]
    assert len(said) == 1 and "warning: OpenGL through EGL is unavailable" in said[0], proc.stderr


def test_osmesa_renders_what_egl_renders(tmp_path):
    """Each OpenGL renderer's first closed-form scene through OSMesa (a subprocess) and through this process's
    context: bit-identical.  Both are Mesa's llvmpipe with the same shaders and state, and the comparison
    over every image of benchmarks/image_hashes.py (282 images) measured no bit different; a difference
    would be a context set up differently (a format, a default state), which this is here to catch."""
    if context.chosen_backend() == "osmesa":
        pytest.skip("this run renders through OSMesa: nothing to compare with")
    out = tmp_path / "osmesa.npz"
    proc = subprocess.run([sys.executable, __file__, str(out)], cwd=ROOT, env=_env(DVR_GL_BACKEND="osmesa"),
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with tempfile.TemporaryDirectory() as folder:
        here = render_cases(Path(folder))
    there = dict(np.load(out))
    assert sorted(there) == sorted(here) and len(here) >= 8
    differ = {case: float(np.abs(there[case] - here[case]).max()) for case in here
              if not np.array_equal(there[case], here[case])}
    assert not differ, f"OSMesa's images differ from EGL's (max abs difference by case): {differ}"


def test_a_conformance_subset_passes_under_osmesa():
    """The conformance suite's first closed-form case of each OpenGL renderer, run by pytest under
    ``DVR_GL_BACKEND=osmesa`` (the whole suite under OSMesa: ``DVR_GL_BACKEND=osmesa pytest
    tests/renderers/test_conformance.py``)."""
    ids = [f"tests/renderers/test_conformance.py::test_closed_form[{'-'.join(case)}]" for case in gl_cases()]
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *ids],
                          cwd=ROOT, env=_env(DVR_GL_BACKEND="osmesa"), capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-3000:]
    assert f"{len(ids)} passed" in proc.stdout


if __name__ == "__main__":  # test_osmesa_renders_what_egl_renders' subprocess: the images into the file argv[1]
    with tempfile.TemporaryDirectory() as scenes:
        np.savez(sys.argv[1], **render_cases(Path(scenes)))
