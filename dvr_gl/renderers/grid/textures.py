"""Uploading volumes and tables as textures, in the volume's own precision.

=========  ============  ===============================================
data       texture       back to data units
=========  ============  ===============================================
uint8      R16F          ``texel`` (0..255: every value exact in half
                         precision)
uint16     R16 (unorm)   ``texel * 65535``
int16      R16 (unorm)   ``texel * 65535 - 32768`` (uploaded + 32768: all
                         65536 values survive, unlike R16_SNORM's -32768)
float32    R32F          ``texel``
=========  ============  ===============================================

uint8 as R16F, not R8: llvmpipe filters an R8 texture in 8-bit fixed point and returns the filtered value
rounded to 8 bits (up to one data unit off; a MIP's image at 53-57 dB on nucleon, ironProt and brainsmall,
where the same settings with R16F give 57-64 dB, and hydrogen's 68 against 80 dB), while it filters R16F in
float; and it draws R16F frames as fast or faster (0.77-1.0x R8's on five of the peers' scenes; 2026-11-29,
the ray caster's README).  The price is two bytes a voxel, which the memory budget counts (:func:`texel_bytes`).

Textures clamp to the edge; 3D textures filter linearly (the shaders use
``texelFetch`` where they want no filtering).
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

#: ``{data type: (moderngl dtype, value scale, value offset, bytes a texel)}``: a texel's data value is
#: ``texel * scale + offset``; :func:`texels` turns the data into what is uploaded.
FORMATS = {
    np.dtype(np.uint8): ("f2", 1.0, 0.0, 2),
    np.dtype(np.uint16): ("nu2", 65535.0, 0.0, 2),
    np.dtype(np.int16): ("nu2", 65535.0, -32768.0, 2),
    np.dtype(np.float32): ("f4", 1.0, 0.0, 4),
}


#: The float16 of each uint8 value (exact): a table lookup converts 1.6x faster than ``astype``.
HALF_OF_BYTE = np.arange(256, dtype=np.float16)


def texels(data: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``data`` as its texture holds it (:data:`FORMATS`): uint8 as float16 (exact), int16 as the uint16 of
    ``x + 32768`` (``x``'s bits with the sign bit flipped), uint16 and float32 as they are; into ``out``
    (that type and shape) where given."""
    if data.dtype == np.uint8:
        return np.take(HALF_OF_BYTE, data, out=out)
    if data.dtype == np.int16:
        return np.bitwise_xor(data.view(np.uint16), np.uint16(0x8000), out=out)
    return data


def texel_bytes(dtype) -> int:
    """Bytes a voxel of ``dtype`` takes in its texture (:data:`FORMATS`; the memory budget's count)."""
    return FORMATS[np.dtype(dtype)][3]


@dataclass
class VolumeTexture:
    texture: moderngl.Texture3D
    value_scale: float    # data value = texel * value_scale + value_offset
    value_offset: float
    nbytes: int

    def uniforms(self) -> dict:
        """What turns its texels back into data values (bound with it: :meth:`dvr_gl.gl.frame.GLFrame.bind`)."""
        return {"u_value_scale": self.value_scale, "u_value_offset": self.value_offset}


def _texture3d(ctx, data: np.ndarray, components: int, dtype: str) -> moderngl.Texture3D:
    nz, ny, nx = data.shape[:3]
    # The array itself (buffer protocol): tobytes() would copy it first, 45 ms for 64 MB.
    tex = ctx.texture3d((nx, ny, nz), components, np.ascontiguousarray(data), dtype=dtype)
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    tex.repeat_x = tex.repeat_y = tex.repeat_z = False
    return tex


def upload_volume(ctx, volume) -> VolumeTexture:
    """The scalar volume as R16F, R16 or R32F (see the module table)."""
    dtype, scale, offset, size = FORMATS[volume.data.dtype]
    data = volume.data
    if data.dtype in (np.uint8, np.int16):
        return VolumeTexture(_converted_texture3d(ctx, data), scale, offset, data.size * size)
    return VolumeTexture(_texture3d(ctx, data, 1, dtype), scale, offset, data.size * size)


SLAB_BYTES = 4 << 20  # slices converted and written at a time: a cache-sized buffer


def _converted_texture3d(ctx, data: np.ndarray) -> moderngl.Texture3D:
    """uint8 (as float16) or int16 (as the uint16 of ``x + 32768``) converted by :func:`texels` and written a
    slab of slices at a time through one small buffer: no converted copy of the volume (int16, the CT bunny's
    190 MB: 40-250 ms less on the first frame than one whole-volume flip, whose cost is mostly the fresh pages
    of its output)."""
    kind = FORMATS[data.dtype][0]
    nz, ny, nx = data.shape
    tex = ctx.texture3d((nx, ny, nz), 1, None, dtype=kind)
    slab = max(1, SLAB_BYTES // (2 * nx * ny))
    buf = np.empty((min(slab, nz), ny, nx), np.float16 if data.dtype == np.uint8 else np.uint16)
    for z0 in range(0, nz, slab):
        k = min(slab, nz - z0)
        texels(np.ascontiguousarray(data[z0:z0 + k]), out=buf[:k])
        tex.write(buf[:k], viewport=(0, 0, z0, nx, ny, k))
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    tex.repeat_x = tex.repeat_y = tex.repeat_z = False
    return tex


def upload_field(ctx, data: np.ndarray) -> moderngl.Texture3D:
    """A float32 multi-channel field ``(nz, ny, nx, C)``: classified RGBA, gradients."""
    return _texture3d(ctx, data.astype(np.float32), data.shape[3], "f4")


def upload_table(ctx, table: np.ndarray) -> moderngl.Texture:
    """A transfer-function table ``(N, 4)`` as an N x 1 RGBA32F texture (fetched, not filtered)."""
    tex = ctx.texture((len(table), 1), 4, np.ascontiguousarray(table, dtype=np.float32).tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    tex.repeat_x = tex.repeat_y = False
    return tex


def central_difference_gradients(volume) -> np.ndarray:
    """Gradients at the voxels, ``(nz, ny, nx, 3)`` float32 in data units per world unit:
    central differences with indices clamped to the edge, the same as central differences
    of the reconstructed field taken one voxel apart (every filter is linear in the samples)."""
    data = volume.data.astype(np.float64)
    out = np.empty(data.shape + (3,), np.float32)
    for axis_xyz, axis_zyx in ((0, 2), (1, 1), (2, 0)):
        n = data.shape[axis_zyx]
        up = np.take(data, np.minimum(np.arange(n) + 1, n - 1), axis=axis_zyx)
        down = np.take(data, np.maximum(np.arange(n) - 1, 0), axis=axis_zyx)
        out[..., axis_xyz] = (up - down) / (2.0 * volume.spacing[axis_xyz])
    return out
