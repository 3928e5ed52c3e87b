"""The headless GL path: context, info, shader composition, compile errors, missing EGL."""

import os
import subprocess
import sys

import numpy as np
import pytest

from dvr_gl.errors import GLUnavailableError, ShaderError
from dvr_gl.gl import shaders
from dvr_gl.gl.context import create_context, gl_info
from dvr_gl.gl.selftest import VALUE, render_selftest, selftest
from judges import renderers

# the GL grid renderers that pre-integrate (and classify after sampling): they cache lookup tables
PREINTEGRATING = renderers("classification", "preintegrated", kind="grid", gl=True)


def test_context_and_info(gl_context):
    info = gl_info(gl_context)
    assert info["max_3d_texture_size"] >= 256
    assert info["vendor"] and info["renderer"] and info["version"]
    assert gl_context.version_code >= 330


def test_selftest_renders_float_values_in_image_row_order(gl_context):
    assert selftest(gl_context) is None
    img = render_selftest(gl_context, 4, 3)
    np.testing.assert_array_equal(img[0, :, 0], [0.5, 1.5, 2.5, 3.5])
    np.testing.assert_array_equal(img[:, 0, 1], [2.5, 1.5, 0.5])  # row 0 is the top
    assert img[1, 1, 2] == np.float32(VALUE) != np.float32(round(VALUE * 255) / 255)



@pytest.mark.parametrize("height", [1, 5, 20])
def test_frame_read_turns_rows_top_down(gl_context, height):
    """GLFrame.read turns GL's bottom-up rows over in place, a few at a time (odd counts, several
    blocks): row 0 is the top, and the unflipped read is the rows as stored; both fresh and writable."""
    from dvr_gl.gl.frame import GLFrame

    texels = np.arange(3 * height * 2, dtype=np.float32).reshape(height, 3, 2)  # GL rows, bottom up
    tex = gl_context.texture((3, height), 2, texels.tobytes(), dtype="f4")
    fbo = gl_context.framebuffer([tex])
    try:
        np.testing.assert_array_equal(GLFrame.read(fbo, 3, height, components=2), texels[::-1])
        stored = GLFrame.read(fbo, 3, height, components=2, flip=False)
        np.testing.assert_array_equal(stored, texels)
        assert stored.flags.writeable and stored.flags.c_contiguous
    finally:
        fbo.release()
        tex.release()

def test_includes_and_defines_are_expanded_with_origins():
    src = shaders.load_shader("selftest.frag", {"SELFTEST_VALUE": "0.5", "FLAG": True, "OFF": False})
    lines = src.text.splitlines()
    assert lines[0].startswith("#version")
    assert "#define FLAG" in lines and "#define SELFTEST_VALUE 0.5" in lines
    assert not any("OFF" in ln for ln in lines)
    assert not any("#include" in ln for ln in lines)
    line = next(i for i, ln in enumerate(lines, 1) if "vec2 pixel_centre()" in ln)
    assert src.where(line) == "common/pixel.glsl line 4"


@pytest.fixture
def broken_shaders(tmp_path, monkeypatch):
    (tmp_path / "common").mkdir()
    (tmp_path / "common" / "bad.glsl").write_text("// a snippet\nfloat broken() {\n    return vec3(1.0);\n}\n")
    (tmp_path / "fullscreen.vert").write_text(shaders.load_shader("fullscreen.vert").text)
    (tmp_path / "bad.frag").write_text('#version 330 core\n#include "common/bad.glsl"\nout vec4 c;\n'
                                       'void main() { c = vec4(broken()); }\n')
    (tmp_path / "noversion.frag").write_text("void main() {}\n")
    monkeypatch.setattr(shaders, "LIBRARY", tmp_path)
    return tmp_path


def test_compile_errors_name_the_file_and_line(gl_context, broken_shaders):
    with pytest.raises(ShaderError, match=r"GLSL compile failed in common/bad.glsl line 3: .*vec3"):
        shaders.create_program(gl_context, "fullscreen.vert", "bad.frag")
    with pytest.raises(ShaderError, match="must start with a #version line"):
        shaders.load_shader("noversion.frag")
    with pytest.raises(ShaderError, match="shader file missing.frag not found"):
        shaders.load_shader("missing.frag")


def test_programs_are_cached_per_feature_set(gl_context):
    a = shaders.create_program(gl_context, "fullscreen.vert", "selftest.frag", {"SELFTEST_VALUE": "1.0"})
    b = shaders.create_program(gl_context, "fullscreen.vert", "selftest.frag", {"SELFTEST_VALUE": "1.0"})
    c = shaders.create_program(gl_context, "fullscreen.vert", "selftest.frag", {"SELFTEST_VALUE": "2.0"})
    assert a is b and a is not c


def test_missing_egl_library_names_the_package():
    with pytest.raises(GLUnavailableError, match="could not be loaded; install .*apt install libegl1"):
        create_context("egl", libegl="libEGL_does_not_exist.so.1")


def test_no_egl_driver_is_one_line_and_nonzero_exit():
    """With no EGL vendor driver visible and EGL asked for, `dvr info` explains in one line what to install
    (with the backend left to choose, OSMesa renders: tests/gl/test_backends.py)."""
    env = dict(os.environ, __EGL_VENDOR_LIBRARY_FILENAMES="/nonexistent/egl_vendor.json", DVR_GL_BACKEND="egl")
    proc = subprocess.run([sys.executable, "-m", "dvr_gl.apps", "info"], env=env, capture_output=True, text=True)
    assert proc.returncode == 1
    last = proc.stderr.strip().splitlines()
    assert len(last) == 1 and "libegl-mesa0" in last[0] and "Traceback" not in proc.stderr


def test_renderers_with_their_own_contexts_interleave():
    """Each renderer owns a context and the newest is current after creation: an older renderer
    must make its own current (it once rendered empty images into the newer one's context),
    and closing one must not release objects in another's."""
    from conftest import small_scene
    from dvr_gl.renderers import create_renderer

    scenes = [small_scene({"camera.azimuth": a, "renderer.classification": c, "image.width": 16,
                           "image.height": 16}) for a, c in [(0.0, "post"), (0.0, "preintegrated"), (30.0, "post")]]
    names = list(reversed(PREINTEGRATING))
    alone = {}
    for name in names:
        with create_renderer(name) as r:
            alone[name] = [r.render(s) for s in scenes]
    renderers = []
    try:
        for i, s in enumerate(scenes):
            for k, name in enumerate(names):
                if k == len(renderers):              # created between the others' frames
                    renderers.append(create_renderer(name))
                assert np.array_equal(renderers[k].render(s), alone[name][i]), (name, i)
        renderers.pop(0).close()                     # the oldest goes; the others keep working
        for name, r in zip(names[1:], renderers):
            assert np.array_equal(r.render(scenes[0]), alone[name][0]), name
    finally:
        for r in renderers:
            r.close()


@pytest.mark.parametrize("name", PREINTEGRATING)
@pytest.mark.parametrize("budget", [None, 0.2])
def test_a_new_view_uploads_nothing(gl_context, name, budget):
    """Textures and tables are cached across frames (a tuple in a cache key once missed every time,
    re-uploading the volume each frame).  Bricks that do not all fit the budget take turns in one
    texture; the tables stay."""
    import dataclasses

    from conftest import small_scene
    from dvr_gl.renderers import create_renderer

    overrides = {"volume.size": 48, "renderer.classification": "preintegrated"}
    if budget:
        overrides["renderer.texture_budget_mb"] = budget   # 48^3 float32 is 0.42 MB
    scene = small_scene(overrides)
    moved = scene.replace(camera=dataclasses.replace(scene.camera, eye=tuple(np.add(scene.camera.eye, 0.5))))
    with create_renderer(name, ctx=gl_context) as r:
        r.render(scene)
        assert (r.stats["bricks"] == 1) == (budget is None)
        before = {what: entry[1] for what, entry in r._cache.items()}
        r.render(moved)
        kept = [what for what, value in before.items() if r._cache[what][1] is value]
        streamed = {"view volume", "stack 0", "stack 1", "stack 2"} if budget else set()
        assert set(before) - set(kept) <= streamed and "lut" in kept and "preintegration" in kept
