"""What the splatting renderer's tests share: an opaque transfer function and one GL renderer per module."""

import pytest

from dvr_gl.renderers.splatting.renderer import SplattingRenderer

#: Opaque enough that slabs and splats overlap visibly (scalar, r, g, b, opacity per point).
OPAQUE_TF = {"transfer_function.points": [[0, 0.2, 0.4, 0.9, 0.0], [0.3, 1.0, 0.8, 0.3, 0.5], [1, 1.0, 1.0, 1.0, 0.9]]}


@pytest.fixture(scope="module")
def splatting(shared_gl_context):
    """A splatting renderer on the shared GL context, closed after the module's tests."""
    r = SplattingRenderer(ctx=shared_gl_context)
    yield r
    r.close()
