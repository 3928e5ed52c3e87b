"""A renderer's own shader root: sources found there before the common library, includes across both,
the same name in two roots taken from the first, and the error naming every root searched.  A renderer in
another package brings its shaders this way (docs/plugins.md, "Shaders")."""

import numpy as np
import pytest

from dvr_gl.errors import ShaderError
from dvr_gl.gl import shaders


def _own_root(tmp_path, value):
    root = tmp_path / f"own{value}"
    root.mkdir()
    # includes a common library snippet (pixel.glsl) and one of its own
    (root / "value.glsl").write_text(f"float own_value() {{ return {value}; }}\n")
    (root / "mine.frag").write_text('#version 330 core\n#include "common/pixel.glsl"\n#include "value.glsl"\n'
                                    "out vec4 colour;\n"
                                    "void main() { colour = vec4(own_value(), pixel_centre().x, 0.0, 1.0); }\n")
    return root


def _draw(ctx, program):
    fbo = ctx.simple_framebuffer((2, 2), components=4, dtype="f4")
    fbo.use()
    ctx.vertex_array(program, []).render(vertices=3)
    return np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(2, 2, 4)


def test_a_program_from_a_root_outside_the_package(gl_context, tmp_path):
    first, second = _own_root(tmp_path, 0.25), _own_root(tmp_path, 0.75)
    a = shaders.create_program(gl_context, "fullscreen.vert", "mine.frag", roots=(first,))
    image = _draw(gl_context, a)
    assert np.allclose(image[..., 0], 0.25) and np.allclose(image[..., 1], [[0.5, 1.5], [0.5, 1.5]])
    # the same names in two roots: the first root's, and a program of its own (the cache keys the roots)
    b = shaders.create_program(gl_context, "fullscreen.vert", "mine.frag", roots=(second, first))
    assert b is not a and np.allclose(_draw(gl_context, b)[..., 0], 0.75)


def test_a_missing_name_lists_every_root(tmp_path):
    with pytest.raises(ShaderError, match=f"absent.frag not found in {tmp_path}, .*gl/shaders"):
        shaders.load_shader("absent.frag", roots=(tmp_path,))
