"""Opaque meshes drawn by GL (``[[renderer.geometry]]``, :mod:`dvr_gl.geometry`): every triangle
rasterized with a depth buffer into one RGBA32F target, the nearest surface's shaded colour in rgb and
its distance along the pixel's ray in a (:data:`NO_SURFACE` where there is none).  A GL renderer ends
its rays or slices there (its shaders' ``GEOMETRY``) and the frame is composited over the layer on the host.
"""

from __future__ import annotations

import moderngl
import numpy as np

from .. import limits
from ..geometry import over_surface, scene_meshes
from ..gl.geometry import box_corners, clip_planes, gl_matrix, projection_matrix, view_matrix
from ..gl.lights import set_uniform, shading_uniforms
from ..gl.shaders import create_program
from ..sandbox import check_bytes

NO_SURFACE = 3.0e38  # t where no surface covers a pixel


#: Host and GL memory per triangle drawn: float64 corners, normals and colours (216 bytes), their float32
#: copy and the vertex buffer (108 each), the face normals and the mask (about 100), with a margin.
BYTES_PER_GL_TRIANGLE = 640
BYTES_PER_LAYER_PIXEL = 80  # the RGBA32F target, its depth, the read-back and the composited layer


def check_layer_memory(meshes, image) -> None:
    """Refuse, before anything is allocated, a layer whose triangles and pixels exceed the memory budget."""
    triangles = sum(len(mesh.triangles) for mesh, _ in meshes)
    check_bytes(triangles * float(BYTES_PER_GL_TRIANGLE) + image.width * image.height * float(BYTES_PER_LAYER_PIXEL),
                f"drawing {triangles} triangles (renderer.geometry)", "use a smaller mesh (fewer triangles)")


def layer_work(positions: np.ndarray, view_projection: np.ndarray, image) -> "limits.Work":
    """The rasterizer's work for the triangles ``positions`` ``(3T, 3)``: each triangle's box on the image
    in pixels (the whole image where a corner lies behind the eye, none where all do), plus one for its setup, in the GL
    renderers' unit (fragments are samples of the same cost on llvmpipe).  Only huge or many large
    triangles come near the bound (327k small ones at 256x256: about 1e6)."""
    clip = np.concatenate([positions, np.ones((len(positions), 1))], axis=1) @ view_projection.T
    w = clip[:, 3].reshape(-1, 3)
    size = np.array([image.width, image.height], dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        pixel = ((clip[:, :2] / clip[:, 3:4] + 1.0) * 0.5 * size).reshape(-1, 3, 2)
        lo = np.clip(np.floor(pixel.min(axis=1)), 0, size)
        hi = np.clip(np.ceil(pixel.max(axis=1)), 0, size)
    area = np.prod(np.maximum(hi - lo, 0.0), axis=1)
    area = np.where((w > 0).all(axis=1) & np.isfinite(area), area, size.prod())
    area = np.where((w <= 0).all(axis=1), 0.0, area)  # wholly behind the eye: clipped away
    triangles = len(area)
    return limits.Work(float(area.sum()) + triangles, "gpu samples",
                       f"{triangles} triangles covering about {float(area.sum()):.3g} pixels of their boxes",
                       "use a mesh with fewer or smaller triangles, or lower --size")


class SurfaceLayer:
    """The frame's surfaces: ``texture`` (for the passes that end rays there) and ``rgba`` ``(H, W, 4)``
    premultiplied (alpha 1 where a surface is seen) for compositing under the volume."""

    def __init__(self, ctx, scene, name: str = "the renderer"):
        img, cam = scene.image, scene.camera
        meshes = scene_meshes(scene.renderer)
        check_layer_memory(meshes, img)
        corners, normals, colours = [], [], []
        for mesh, rgb in meshes:
            c = mesh.corners
            face = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
            length = np.linalg.norm(face, axis=1)
            keep = length > 0
            corners.append(c[keep].reshape(-1, 3))
            normals.append(np.repeat(face[keep] / length[keep, None], 3, axis=0))
            colours.append(np.broadcast_to(rgb, (3 * int(keep.sum()), 3)))
        vertices = np.concatenate([np.concatenate(corners), np.concatenate(normals), np.concatenate(colours)], axis=1)
        if not len(vertices):  # only degenerate triangles: they cover nothing, a pixel's ray sees no surface
            vertices = np.zeros((3, 9))
        lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.field.bounds)
        points = np.concatenate([box_corners(lo, hi), vertices[:, :3]])
        near, _ = clip_planes(cam, lo, hi)
        far = float(((points - np.asarray(cam.eye)) @ np.asarray(cam.basis()[0])).max())
        far = max(far, near) * 1.01 + 1e-6 * float(np.linalg.norm(hi - lo)) + 1e-6
        view_projection = projection_matrix(cam, img.width / img.height, near, far) @ view_matrix(cam)
        limits.check_work(layer_work(vertices[:, :3], view_projection, img), name)
        defines = {"CAMERA_ORTHOGRAPHIC": cam.projection == "orthographic"}
        lights = scene.renderer.shading.lights
        if lights:
            defines.update(SHADING=True, NUM_LIGHTS=len(lights))
        program = create_program(ctx, "geometry/surface.vert", "geometry/surface.frag",
                                 {k: v for k, v in defines.items() if v})
        colour = ctx.texture((img.width, img.height), 4, dtype="f4")
        depth = ctx.depth_renderbuffer((img.width, img.height))
        fbo = ctx.framebuffer(color_attachments=[colour], depth_attachment=depth)
        vbo = ctx.buffer(np.ascontiguousarray(vertices, dtype=np.float32).tobytes())
        # an attribute the program does not read (the normal, without lights) is skipped as padding
        used = [name for name in ("position", "normal", "colour") if name in program]
        layout = " ".join("3f" if name in used else "12x" for name in ("position", "normal", "colour"))
        vao = ctx.vertex_array(program, [(vbo, layout, *used)])
        try:
            fbo.use()
            ctx.viewport = (0, 0, img.width, img.height)
            ctx.clear(0.0, 0.0, 0.0, NO_SURFACE, depth=1.0)
            ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
            ctx.enable(moderngl.DEPTH_TEST)
            program["u_view_projection"].write(gl_matrix(view_projection))
            uniforms = {"u_eye": tuple(cam.eye), "u_forward": tuple(cam.basis()[0]),
                        **shading_uniforms(scene.renderer.shading)}
            for name, value in uniforms.items():
                set_uniform(program, name, value)
            vao.render(moderngl.TRIANGLES)
            ctx.disable(moderngl.DEPTH_TEST)
            layer = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32)
            layer = layer.reshape(img.height, img.width, 4)[::-1]  # GL rows run bottom up
        finally:
            vao.release()
            vbo.release()
            fbo.release()
            depth.release()
        self.texture = colour
        seen = layer[..., 3] < 0.5 * NO_SURFACE
        self.rgba = np.where(seen[..., None], np.concatenate([layer[..., :3], np.ones(seen.shape + (1,),
                                                                                      np.float32)], axis=-1), 0.0)

    def release(self):
        self.texture.release()


def with_surfaces(renderer, scene, draw_volume) -> np.ndarray:
    """A GL renderer's (:class:`~dvr_gl.renderers.base.GLRenderer`) frame with the scene's meshes:
    ``draw_volume(scene, textures)`` draws the volume (``textures``: ``u_geometry``, the layer its
    samples end at, or none without meshes), composited over the layer.  A scene without meshes draws nothing more."""
    if not getattr(scene.renderer, "geometry", None):
        return draw_volume(scene, {})
    renderer.activate()
    layer = SurfaceLayer(renderer.ctx, scene, renderer.name)
    try:
        image = draw_volume(scene, {"u_geometry": layer.texture})
    finally:
        layer.release()
    return over_surface(image, layer.rgba).astype(np.float32)
