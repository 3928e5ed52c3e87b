"""Ray casting from cell to cell in GL (see the package doc and ``docs/meshes.md``).

A frame is two draws.  The mesh's boundary faces are drawn into per-pixel linked lists of the
faces where each pixel's ray enters the mesh (``entry_lists.frag``: a node buffer, an image of
list heads and an atomic counter); then one full-screen pass walks every pixel's ray from its
nearest entry through the cells' face neighbours, on at the next entry beyond each exit
(``walk.frag``).  The mesh's textures are those of projected tetrahedra (:mod:`..mesh.textures`), with
the face neighbours beside them.
"""

from __future__ import annotations

import time

import moderngl
import numpy as np

from ...errors import SceneError
from ...fields.mesh_rays import boundary_faces, face_neighbours
from ...gl.shaders import create_program, shader_root
from ..mesh import SHADERS as MESH_SHADERS
from ..mesh.textures import MODES, ROW, MeshRenderer, rows

#: Its own GLSL, then the kit's (before the common library).
SHADERS = (shader_root(__file__), MESH_SHADERS)

NODE_BYTES = 16          # a list node: cell, t, next, padding (entry_lists.frag)
# The node buffer's first size, nodes a pixel; it grows to what a frame needed (the blunt fin at
# 512x512: 0.26 entries a pixel, the notched part 0.25)
FIRST_NODES_PER_PIXEL = 1
TOUCHING = 1e-5          # an entry this close before the last exit (relative to the mesh's diagonal) meets it


class WalkMesh:
    """What the walk needs per mesh beside the textures: each cell's face neighbours (a texture of
    ``ROW`` texels a row) and the boundary faces' vertices with their cell and outward normal
    (a vertex buffer, three vertices a face)."""

    def __init__(self, ctx, mesh, textures):
        neighbours = face_neighbours(mesh.tets)
        texels = rows(neighbours, np.int32)
        self.neighbours = ctx.texture((ROW, texels.shape[0]), 4, texels.tobytes(), dtype="i4")
        self.neighbours.filter = (moderngl.NEAREST, moderngl.NEAREST)
        # the boundary from the same pairing of faces (a face shared by more than two cells: the
        # first two pair up, the others are boundary), not the visibility order's whole adjacency
        boundary_cell, boundary_corners, boundary_normal = boundary_faces(mesh.points, mesh.tets, neighbours)
        corners = (boundary_corners - textures.centre).astype(np.float32).reshape(-1, 3)
        cells = np.repeat(boundary_cell.astype(np.uint32), 3)
        normals = np.repeat(boundary_normal.astype(np.float32), 3, axis=0)
        self.faces = len(boundary_cell)
        vertices = np.concatenate([corners.view(np.uint32), cells[:, None], normals.view(np.uint32)], axis=1)
        self.boundary = ctx.buffer(vertices.tobytes()) if self.faces else None
        lo, hi = (np.asarray(b, float) for b in mesh.bounds)
        self.touching = TOUCHING * float(np.linalg.norm(hi - lo))

    def release(self):
        self.neighbours.release()
        if self.boundary is not None:
            self.boundary.release()


class CellRaycastRenderer(MeshRenderer):
    name = "cell-raycast"
    description = "ray casting from cell to cell through meshes in GL, no visibility order"
    folded_planes = True

    def __init__(self, ctx=None):
        super().__init__(ctx)
        self._nodes = None    # (capacity in nodes, buffer)
        self._counter = None
        self._walk_stats = False

    def _mesh_extra(self, mesh, textures):
        return WalkMesh(self.ctx, mesh, textures)

    # --- resources ---

    def _node_buffer(self, nodes: int):
        """The list nodes' storage buffer, for at least ``nodes`` nodes (grown, never shrunk)."""
        if self._nodes is None or self._nodes[0] < nodes:
            limit = int(self.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)) // NODE_BYTES
            if nodes > limit:
                raise SceneError(f"the rays enter the mesh {nodes} times in all, more than the {limit} list nodes "
                                 f"this GL's storage buffers hold: use a smaller image, or projected-tetrahedra")
            if self._nodes is not None:
                self._nodes[1].release()
            capacity = min(max(nodes, 1), limit)
            self._nodes = (capacity, self.ctx.buffer(reserve=NODE_BYTES * capacity))
        if self._counter is None:
            self._counter = self.ctx.buffer(reserve=4)
        return self._nodes

    def _lists_target(self, width: int, height: int):
        """The lists' heads (an r32ui image) and a framebuffer of that size for their draw (which
        writes no colour)."""
        def make(size):
            heads = self.ctx.texture(size, 1, dtype="u4")
            unused = self.ctx.texture(size, 1, dtype="f1")
            return [heads, unused], self.ctx.framebuffer([unused])
        (heads, _), fbo = self.framebuffer("lists", width, height, make)
        return heads, fbo

    # --- a frame ---

    def _draw_volume(self, scene, surfaces: dict) -> np.ndarray:
        mesh = scene.field
        start = time.perf_counter()
        textures, walk = self._mesh_resources(mesh)
        self.ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        heads, entries = self._entry_lists(scene, textures, walk)
        listed = time.perf_counter()
        starts = self._start_cells(scene) if self._reaches_near_plane(scene) else None
        image = self._walk(scene, textures, walk, heads, starts, surfaces)
        now = time.perf_counter()
        self.stats = {"seconds": now - start, "lists_seconds": listed - start, "walk_seconds": now - listed,
                      "entries": entries, "start_cells": starts is not None, "cells": textures.cells,
                      "cells_per_second": textures.cells / max(now - start, 1e-12)}
        if scene.renderer.compositing == "emission_absorption" or self._walk_stats:
            return image.astype(np.float32)
        return self._resolve(scene, image.astype(np.float64)).astype(np.float32)

    def walk_stats(self, scene) -> np.ndarray:
        """``(height, width, 4)``: per pixel, the walk's steps through cells, its walks (entries
        followed), the walks given up after steps that did not advance, and where the ray's walking
        ended (its ``t``); for tests and tracing."""
        self._walk_stats = True
        try:
            return self.render(scene)
        finally:
            self._walk_stats = False

    def _entry_lists(self, scene, textures, walk):
        """Draw the boundary into the per-pixel lists of entering faces; again, with room enough, if
        the node buffer overflowed.  Returns the heads' texture and the number of entries."""
        img = scene.image
        heads, fbo = self._lists_target(img.width, img.height)
        capacity, nodes = self._node_buffer(self._nodes[0] if self._nodes
                                            else FIRST_NODES_PER_PIXEL * img.width * img.height)
        if walk.boundary is None:
            heads.write(np.zeros((img.height, img.width), np.uint32).tobytes())
            return heads, 0
        program = create_program(self.ctx, "entry_lists.vert", "entry_lists.frag",
                                 {"CAMERA_ORTHOGRAPHIC": scene.camera.projection == "orthographic"},
                                 geometry="entry_lists.geom", roots=SHADERS)
        self._uniforms(program, scene, textures)
        vao = self.ctx.vertex_array(program, [(walk.boundary, "3f 1u 3f", "in_position", "in_cell", "in_normal")])
        try:
            for _ in range(2):
                heads.write(np.zeros((img.height, img.width), np.uint32).tobytes())
                self._counter.write(np.zeros(1, np.uint32).tobytes())
                nodes.bind_to_storage_buffer(0)
                self._counter.bind_to_storage_buffer(1)
                heads.bind_to_image(0, read=True, write=True)
                program["u_capacity"].value = capacity
                fbo.use()
                fbo.viewport = (0, 0, img.width, img.height)
                vao.render(moderngl.TRIANGLES, vertices=3 * walk.faces)
                self.ctx.memory_barrier()
                used = int(np.frombuffer(self._counter.read(), np.uint32)[0])
                if used <= capacity:
                    return heads, used
                capacity, nodes = self._node_buffer(used)
        finally:
            vao.release()
        raise AssertionError("the lists overflowed a buffer made for them")  # the second draw had room

    def _start_cells(self, scene) -> np.ndarray:
        """``(height, width)`` uint32: the cell holding each pixel's ray at its start (the camera's near
        plane) + 1, 0 outside every cell, rows from the bottom as GL's; located on the host (the bins
        of :mod:`dvr_gl.fields.mesh_locate`), as rays starting inside the mesh have no entering face."""
        cam, img, mesh = scene.camera, scene.image, scene.field
        o, d = cam.pixel_rays(img.width, img.height)
        cells = mesh.reconstruct().locator.locate(o + cam.near_distance(d)[:, None] * d)
        return (cells + 1).astype(np.uint32).reshape(img.height, img.width)[::-1]

    def _walk(self, scene, textures, walk, heads, starts, surfaces) -> np.ndarray:
        """The full-screen walk; the image, rows from the top."""
        cam, img, r, tf = scene.camera, scene.image, scene.renderer, scene.transfer_function
        mode = r.compositing
        defines = {MODES[mode]: True, "FOLDED_PLANES": True, "CAMERA_ORTHOGRAPHIC": cam.projection == "orthographic",
                   "START_CELLS": starts is not None, "WALK_STATS": self._walk_stats,
                   **self._kept_part_defines(scene, surfaces)}
        if mode == "emission_absorption":
            defines.update(ALPHA_MODEL=tf.opacity_model == "alpha", TF_COUNT=len(tf.points),
                           TF_POW2=1 << len(tf.points).bit_length())
        program = create_program(self.ctx, "fullscreen.vert", "walk.frag", defines, roots=SHADERS)
        self._uniforms(program, scene, textures)
        start_tex = None
        bound = {**dict(textures.textures), "u_neighbours": walk.neighbours, **surfaces}
        if starts is not None:
            start_tex = self.ctx.texture((img.width, img.height), 1, np.ascontiguousarray(starts).tobytes(), dtype="u4")
            start_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            bound["u_start"] = start_tex
        self.bind(program, {"u_touching": walk.touching, "u_opaque": r.ert_threshold}, bound)
        self._nodes[1].bind_to_storage_buffer(0)
        heads.bind_to_image(0, read=True, write=False)
        (_,), fbo = self.target("image", img.width, img.height)
        fbo.use()
        fbo.viewport = (0, 0, img.width, img.height)
        vao = self.ctx.vertex_array(program, [])
        try:
            vao.render(moderngl.TRIANGLES, vertices=3)
            return self.read(fbo, img.width, img.height)
        finally:
            vao.release()
            if start_tex is not None:
                start_tex.release()

    def close(self):
        self.activate()
        for obj in ((self._nodes[1] if self._nodes else None), self._counter):
            if obj is not None:
                obj.release()
        self._nodes = self._counter = None
        super().close()
