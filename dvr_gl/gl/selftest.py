"""A render-and-read-back check of the GL path every GPU renderer relies on:
shaders found and compiled (with an include and a define), a float32 RGBA
target, exact read-back values and row order."""

from __future__ import annotations

import numpy as np

from .context import make_current
from .shaders import create_program

VALUE = 0.123456789  # needs float32: an 8-bit target would round it to 31/255


def render_selftest(ctx, width: int = 7, height: int = 5) -> np.ndarray:
    """Render the self-test pattern; rows returned top first, as images are stored."""
    make_current(ctx)  # another context may have been made current, or released, since
    program = create_program(ctx, "fullscreen.vert", "selftest.frag", {"SELFTEST_VALUE": repr(VALUE)})
    target = ctx.texture((width, height), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[target])
    vao = ctx.vertex_array(program, [])
    try:
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0)
        vao.render(mode=ctx.TRIANGLES, vertices=3)
        data = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
    finally:
        vao.release()
        fbo.release()
        target.release()
    return data.reshape(height, width, 4)[::-1]


def selftest(ctx) -> str | None:
    """None when the GL path works, else what is wrong."""
    img = render_selftest(ctx)
    h, w = img.shape[:2]
    expect_x = np.arange(w) + 0.5
    expect_y = (h - 1 - np.arange(h)) + 0.5  # row 0 of the image is the top: GL's highest y
    if not np.allclose(img[0, :, 0], expect_x) or not np.allclose(img[:, 0, 1], expect_y):
        return "pixel centres or row order are wrong"
    if not np.all(img[..., 2] == np.float32(VALUE)):
        return "float32 render target does not hold float values"
    return None
