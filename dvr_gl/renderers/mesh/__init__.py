"""The mesh kit: what the renderers of unstructured (tetrahedral) meshes share.

:mod:`.textures` puts a :class:`~dvr_gl.fields.mesh.TetMesh` into float32 textures and carries the mesh
renderers' frame; ``shaders/`` holds the GLSL they include (the cells' fetch, the transfer-function
segment, the clipped part of a cell, growing a cell's footprint).  Only the renderers that draw meshes
import it.
"""

from ...gl.shaders import shader_root

#: The kit's GLSL folder, searched after a mesh renderer's own.
SHADERS = shader_root(__file__)
