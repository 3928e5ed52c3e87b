"""The transfer function's tables as textures: the lookup table (one RGBA row over the table's value
domain), scattering's albedo column beside it, and the pre-integration table (N x N, front value by
back value); checked against the GL limits before they are made (:func:`check_tables`) and kept in the
frame's cache by what they were made from (:func:`table_textures`).

Used by the grid renderers (:mod:`.sampling`) and by a splatter's sheets (the lookup table).
"""

from __future__ import annotations

import moderngl
import numpy as np

from ... import limits
from ...preintegration import preintegrate
from .textures import upload_table


class TableTexture:
    """A transfer-function table and its texture (the table knows its value domain)."""

    def __init__(self, ctx, lut):
        self.lut = lut
        self.texture = upload_table(ctx, lut.table)


class TransferFunction2DTexture:
    """A 2D transfer function's table (:class:`~dvr_gl.transfer_function_2d.TransferFunction2DLUT`) as an NV x NG
    RGBA32F texture, fetched (``common/transfer_function_2d.glsl``); it brings the uniforms that map to it."""

    def __init__(self, ctx, table):
        self.table = table
        nv, ng = table.table.shape[:2]
        self.texture = ctx.texture((nv, ng), 4, table.texels().tobytes(), dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.repeat_x = self.texture.repeat_y = False

    def uniforms(self) -> dict:
        return self.table.uniforms()


class PreintegrationTexture:
    """A pre-integration table and its N x N RGBA32F texture (x: front value, y: back value)."""

    def __init__(self, ctx, table):
        self.table = table
        data = np.ascontiguousarray(table.table.transpose(1, 0, 2), dtype=np.float32)  # rows: back value
        self.texture = ctx.texture((table.size, table.size), 4, data.tobytes(), dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.repeat_x = self.texture.repeat_y = False

    def uniforms(self) -> dict:
        """The table's size and the map from data values to its texels (``common/classify.glsl``)."""
        lo, hi = self.table.domain
        return {"u_preint_size": self.table.size, "u_preint_lo": lo,
                "u_preint_scale": (self.table.size - 1) / (hi - lo)}


def check_tables(scene, gl: "limits.GLLimits"):
    """The transfer-function table (one texture row) and the pre-integration table (N x N) against the
    texture limit, and the table's memory."""
    r = scene.renderer
    limits.check_table("renderer.lut_size", r.lut_size, gl, "one row")
    limits.check_lut_memory(r.lut_size)
    if r.classification == "preintegrated" and r.compositing == "emission_absorption":
        n = r.preintegration_size
        limits.check_table("renderer.preintegration_size", n, gl, f"{n} x {n} texels")


def lookup_table(frame, scene) -> TableTexture:
    """The frame's lookup table (``frame``: a :class:`~dvr_gl.gl.frame.GLFrame`), made once per transfer
    function and table size."""
    r, tf = scene.renderer, scene.transfer_function
    return frame._cached("lut", (tf, r.lut_size), lambda: TableTexture(frame.ctx, tf.tabulate(r.lut_size)))


def table_textures(frame, scene, defines: dict, slab_length: float) -> dict:
    """The tables a frame with ``defines`` samples: ``u_lut``, scattering's ``u_albedo_lut`` (ALBEDO_TABLE)
    and the pre-integration table ``u_preint`` of slabs ``slab_length`` long (world units)."""
    r, tf = scene.renderer, scene.transfer_function
    out = {"u_lut": lookup_table(frame, scene)}
    if defines.get("TRANSFER_FUNCTION_2D"):  # classified by value and gradient magnitude
        out["u_tf2d"] = frame._cached("transfer function 2d", (tf,),
                                      lambda: TransferFunction2DTexture(frame.ctx, tf.tabulate_2d()))
    if defines.get("ALBEDO_TABLE"):  # scattering's albedo column, at the same nodes (r; gba unused)
        albedo = out["u_lut"].lut.albedo_table
        out["u_albedo_lut"] = frame._cached("albedo lut", (tf, r.lut_size), lambda: upload_table(
            frame.ctx, np.column_stack([albedo, np.zeros((len(albedo), 3))])))
    if "CLASSIFY_PREINTEGRATED" in defines:
        out["u_preint"] = frame._cached(
            "preintegration", (tf, slab_length, r.preintegration_size, r.preintegration, r.lut_size),
            lambda: PreintegrationTexture(frame.ctx, preintegrate(tf, slab_length, r.preintegration_size,
                                                                  r.preintegration, r.lut_size)))
    return out
