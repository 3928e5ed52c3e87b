"""Dear ImGui (imgui-bundle, optional) on a GLFW window, drawn with moderngl.

imgui-bundle's own backends draw with PyOpenGL; the viewer already has moderngl, so this module
is the small part that connects the two: GLFW input events into ImGui's IO queue
(:class:`ImGuiInput`), and ImGui's draw lists and textures (the font atlas, created and updated
as ImGui asks, ``RendererHasTextures``) into moderngl draws (:class:`ImGuiRenderer`).

Import :mod:`imgui_bundle` before :mod:`glfw` (:func:`load_imgui` does): it points pyGLFW at the
GLFW library it ships, so that both use one GLFW.
"""

from __future__ import annotations

import ctypes

import moderngl

from ..gl.context import make_current
from ..gl.shaders import create_program, shader_root

NO_POSITION = 3.4028234663852886e38  # FLT_MAX: ImGui's mouse position for "no mouse"


def load_imgui():
    """The ``imgui`` module of imgui-bundle, or None when the optional extra is not installed."""
    try:
        from imgui_bundle import imgui
    except ImportError:
        return None
    return imgui


class ImGuiRenderer:
    """Draws ImGui's draw data into the current framebuffer with moderngl."""

    def __init__(self, imgui, ctx: moderngl.Context):
        self.imgui, self.ctx = imgui, ctx
        self.program = create_program(ctx, "imgui.vert", "imgui.frag", roots=(shader_root(__file__),))
        self.vbo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.ibo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.vao = ctx.vertex_array(self.program, [(self.vbo, "2f 2f 4f1", "in_position", "in_uv", "in_color")],
                                    index_buffer=self.ibo, index_element_size=imgui.INDEX_SIZE)
        self.textures: dict[int, moderngl.Texture] = {}
        imgui.get_io().backend_flags |= imgui.BackendFlags_.renderer_has_textures
        platform = imgui.get_platform_io()
        platform.renderer_texture_max_width = platform.renderer_texture_max_height = ctx.info["GL_MAX_TEXTURE_SIZE"]

    def _update_textures(self):
        """Create, update or destroy the textures ImGui asks for (the font atlas grows on demand)."""
        imgui = self.imgui
        status = imgui.ImTextureStatus
        for tex in imgui.get_platform_io().textures:
            if tex.status in (status.want_create, status.want_updates):
                texture = self.textures.get(tex.tex_id)
                if texture is None or texture.size != (tex.width, tex.height):
                    if texture is not None:
                        texture.release()
                    texture = self.ctx.texture((tex.width, tex.height), 4)
                    texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
                    texture.repeat_x = texture.repeat_y = False
                    self.textures.pop(tex.tex_id, None)
                    self.textures[texture.glo] = texture
                    tex.set_tex_id(texture.glo)
                texture.write(tex.get_pixels_array().tobytes())
                tex.status = status.ok
            elif tex.status == status.want_destroy:
                texture = self.textures.pop(tex.tex_id, None)
                if texture is not None:
                    texture.release()
                tex.set_tex_id(0)
                tex.status = status.destroyed

    def render(self, draw_data, framebuffer_size: tuple[int, int]):
        make_current(self.ctx)
        self._update_textures()
        fb_w, fb_h = framebuffer_size
        width, height = draw_data.display_size.x, draw_data.display_size.y
        if width <= 0 or height <= 0 or fb_w <= 0 or fb_h <= 0:
            return
        sx, sy = fb_w / width, fb_h / height
        ctx = self.ctx
        ctx.screen.use()
        ctx.viewport = (0, 0, fb_w, fb_h)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        self.program["u_display_size"].value = (width, height)
        self.program["u_texture"].value = 0
        vsize, isize = self.imgui.VERTEX_SIZE, self.imgui.INDEX_SIZE
        try:
            for commands in draw_data.cmd_lists:
                self._write(self.vbo, commands.vtx_buffer.data_address(), commands.vtx_buffer.size() * vsize)
                self._write(self.ibo, commands.idx_buffer.data_address(), commands.idx_buffer.size() * isize)
                for cmd in commands.cmd_buffer:
                    texture = self.textures.get(cmd.tex_ref.get_tex_id())
                    if texture is None or cmd.elem_count == 0:
                        continue
                    x0, y0, x1, y1 = cmd.clip_rect
                    x0, y0 = x0 - draw_data.display_pos.x, y0 - draw_data.display_pos.y
                    x1, y1 = x1 - draw_data.display_pos.x, y1 - draw_data.display_pos.y
                    if x1 <= x0 or y1 <= y0:
                        continue
                    ctx.scissor = (int(x0 * sx), int(fb_h - y1 * sy), int((x1 - x0) * sx), int((y1 - y0) * sy))
                    texture.use(location=0)
                    self.vao.render(moderngl.TRIANGLES, vertices=cmd.elem_count, first=cmd.idx_offset)
        finally:
            ctx.scissor = None
            ctx.disable(moderngl.BLEND)

    @staticmethod
    def _write(buffer: moderngl.Buffer, address: int, size: int):
        if size > buffer.size:
            buffer.orphan(max(size, 2 * buffer.size))
        buffer.write(ctypes.string_at(address, size))

    def release(self):
        for texture in self.textures.values():
            texture.release()
        self.textures.clear()
        for obj in (self.vao, self.vbo, self.ibo):
            obj.release()


def _key_map(imgui, glfw) -> dict:
    K = imgui.Key
    keys = {getattr(glfw, f"KEY_{c}"): getattr(K, c.lower()) for c in "ABCDEFGHIJKLMNOPQRSTUVWXYZ"}
    keys.update({getattr(glfw, f"KEY_{d}"): getattr(K, f"_{d}") for d in "0123456789"})
    keys.update({getattr(glfw, f"KEY_F{n}"): getattr(K, f"f{n}") for n in range(1, 13)})
    named = {"TAB": "tab", "BACKSPACE": "backspace", "ENTER": "enter", "ESCAPE": "escape", "INSERT": "insert",
             "DELETE": "delete", "SPACE": "space", "LEFT": "left_arrow", "RIGHT": "right_arrow", "UP": "up_arrow",
             "DOWN": "down_arrow", "PAGE_UP": "page_up", "PAGE_DOWN": "page_down", "HOME": "home", "END": "end",
             "KP_ENTER": "keypad_enter", "MINUS": "minus", "PERIOD": "period", "COMMA": "comma", "SLASH": "slash",
             "EQUAL": "equal", "LEFT_BRACKET": "left_bracket", "RIGHT_BRACKET": "right_bracket",
             "LEFT_CONTROL": "left_ctrl", "RIGHT_CONTROL": "right_ctrl", "LEFT_SHIFT": "left_shift",
             "RIGHT_SHIFT": "right_shift", "LEFT_ALT": "left_alt", "RIGHT_ALT": "right_alt"}
    keys.update({getattr(glfw, f"KEY_{g}"): getattr(K, i) for g, i in named.items()})
    return keys


class ImGuiInput:
    """Forwards GLFW events to ImGui's IO queue (the viewer's callbacks call these)."""

    def __init__(self, imgui, glfw):
        self.imgui, self.glfw = imgui, glfw
        self.io = imgui.get_io()
        self.keys = _key_map(imgui, glfw)
        K = imgui.Key
        self.modifiers = {K.left_ctrl: K.mod_ctrl, K.right_ctrl: K.mod_ctrl, K.left_shift: K.mod_shift,
                          K.right_shift: K.mod_shift, K.left_alt: K.mod_alt, K.right_alt: K.mod_alt}

    def cursor(self, x: float, y: float):
        self.io.add_mouse_pos_event(x, y)

    def leave(self):
        """The cursor left the window: no position (ImGui's convention, -FLT_MAX), so nothing is hovered."""
        self.io.add_mouse_pos_event(-NO_POSITION, -NO_POSITION)

    def button(self, button: int, pressed: bool):
        if 0 <= button < 5:
            self.io.add_mouse_button_event(button, pressed)

    def scroll(self, dx: float, dy: float):
        self.io.add_mouse_wheel_event(dx, dy)

    def key(self, key: int, action: int):
        imgui_key = self.keys.get(key)
        if imgui_key is None:
            return
        down = action != self.glfw.RELEASE
        self.io.add_key_event(imgui_key, down)
        if imgui_key in self.modifiers:
            self.io.add_key_event(self.modifiers[imgui_key], down)

    def char(self, codepoint: int):
        if 0 < codepoint < 0x10000:
            self.io.add_input_character(codepoint)

    @property
    def wants_text(self) -> bool:
        return self.io.want_text_input
