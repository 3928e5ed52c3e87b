"""The rendered image on the window: a float texture drawn over the render area.

The image (linear RGBA, background already composited, row 0 at the top, any size) is uploaded
to an RGBA32F texture and drawn with ``dvr_gl/viewer/shaders/display.frag``, which encodes it to sRGB
as a PNG screenshot is encoded; a reduced-resolution frame is magnified bilinearly.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..gl.context import make_current
from ..gl.shaders import create_program, shader_root


class ImageDisplay:
    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = create_program(ctx, "fullscreen.vert", "display.frag", roots=(shader_root(__file__),))
        self.vao = ctx.vertex_array(self.program, [])
        self.texture: moderngl.Texture | None = None

    def upload(self, rgba: np.ndarray):
        """Replace the image shown (``(H, W, 4)`` float, linear, background composited)."""
        make_current(self.ctx)
        h, w = rgba.shape[:2]
        if self.texture is None or self.texture.size != (w, h):
            if self.texture is not None:
                self.texture.release()
            self.texture = self.ctx.texture((w, h), 4, dtype="f4")
            self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.texture.repeat_x = self.texture.repeat_y = False
        self.texture.write(np.ascontiguousarray(rgba, dtype=np.float32).tobytes())

    def draw(self, viewport: tuple[int, int, int, int]):
        """Draw the image over ``viewport`` (x, y from the bottom left, width, height; framebuffer pixels)."""
        if self.texture is None:
            return
        make_current(self.ctx)
        self.ctx.screen.use()
        self.ctx.viewport = viewport
        self.ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
        self.texture.use(location=0)
        self.program["u_image"].value = 0
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def release(self):
        if self.texture is not None:
            self.texture.release()
        self.vao.release()
