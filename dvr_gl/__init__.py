"""dvr-gl: direct volume rendering in Python on OpenGL, checked against a float64 CPU reference.

The Python API in one line: ``dvr_gl.render(data, ...)`` (:func:`render`) takes a numpy array indexed
``[z, y, x]``, a field, a volume or scene file, or a :class:`Scene`, and returns an :class:`Image`
(inline in Jupyter; ``.rgba``, ``.srgb8()``, ``.save()``).  The parts: :class:`Scene` and
:func:`load_scene`; the fields (:class:`Volume`, a regular grid; :class:`Field`, the protocol every
data kind implements; several fields in one scene: :class:`FieldSet` of :class:`Member` s, a label map's
:class:`LabelTable`, a :class:`ColorVolume`); :class:`TransferFunction` (and :class:`TransferFunction2D`, over
value and gradient magnitude); :class:`Camera`; the renderers
(:func:`create_renderer`, and :mod:`dvr_gl.renderers.registry` for what is registered); in Jupyter,
:func:`widget` (an interactive view: orbit, pan, zoom and controls, rendered on the kernel's side).
"""

__version__ = "0.1.0"

from .annotations import Annotations, annotate  # noqa: E402
from .api import Image, render, scene_of  # noqa: E402
from .camera import Camera  # noqa: E402
from .camera_path import CameraPath  # noqa: E402
from .errors import DvrError, SceneError, VolumeError  # noqa: E402
from .fields import Field, ParticleSet, SphereField, Volume  # noqa: E402
from .fields.color import ColorVolume  # noqa: E402
from .fields.layers import FieldSet, Member  # noqa: E402
from .io import load_field, load_volume  # noqa: E402
from .labels import LabelTable  # noqa: E402
from .picking import Pick, pick  # noqa: E402
from .renderers import create_renderer, registry  # noqa: E402
from .scene.resolve import Scene, load_scene  # noqa: E402
from .transfer_function import PRESETS, TransferFunction, preset  # noqa: E402
from .transfer_function_2d import TransferFunction2D  # noqa: E402


def widget(data, **options):
    """An interactive notebook view of ``data`` (:func:`dvr_gl.jupyter.widget`; the extra ``widget``)."""
    from .jupyter import widget as make

    return make(data, **options)


__all__ = ["Camera", "ColorVolume", "DvrError", "Field", "FieldSet", "Image", "LabelTable", "Member", "PRESETS",
           "ParticleSet", "Pick", "Scene", "SceneError", "SphereField", "TransferFunction", "TransferFunction2D",
           "Volume", "VolumeError", "create_renderer", "load_field", "load_scene", "load_volume", "pick", "preset",
           "registry", "render", "scene_of", "widget", "__version__"]
__all__ += ["Annotations", "CameraPath", "annotate"]  # issue 43: annotations and camera paths
