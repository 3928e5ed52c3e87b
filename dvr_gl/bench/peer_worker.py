"""One run of ``dvr bench peers``: render one scene with one renderer in a fresh process.

    python peer_worker.py JOB.json

This file runs on its own, with numpy and the one renderer it is asked for: the peers (VTK, vispy,
pygfx) live in a separate benchmark environment where dvr-gl is not installed, so nothing here
imports dvr_gl at the top (only the ``dvr-gl`` runs do, in dvr-gl's own interpreter).

The job (JSON) names the renderer and holds the scene resolved by ``dvr_gl.bench.peers``: the volume
as a ``.npy`` file (``[z, y, x]``, node-centred samples at ``origin + i * spacing``: the box is the
hull of the samples), the transfer function's control points ``[value, r, g, b, alpha]`` in data
units with alpha per ``unit_distance`` (linear colour, not premultiplied), the compositing mode
(``composite``: emission-absorption; ``mip``: the maximum classified once, with the opacity of one
unit distance), the camera as eye, target, up and vertical field of view, the image size and the
sample distance (world units).  The run renders one untimed frame (uploads, shader builds), then
``frames`` timed ones at the image size (wall time of the renderer's own draw call, finished: the
GPU peers wait for completion, dvr-gl reads its float image back), saves the last as ``image.npy``,
renders once more at ``error_size`` for the error against the converged reference (``error.npy``),
and writes ``result.json`` (frame seconds, versions, the settings it used).  Images are float32
RGBA, premultiplied, linear, row 0 at the top, background not applied: what dvr-gl returns.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

# --- geometry and colour shared by every peer (pure numpy; tests/apps/test_bench_peers.py checks them) ---


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def camera_basis(eye, target, up) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(forward, right, up)`` orthonormal, as dvr-gl builds them: right = forward x up."""
    f = _unit(np.subtract(target, eye))
    r = _unit(np.cross(f, _unit(up)))
    return f, r, np.cross(r, f)


def view_matrix(eye, target, up) -> np.ndarray:
    """World to eye coordinates (OpenGL: the camera looks down -z, y up), column vectors."""
    f, r, u = camera_basis(eye, target, up)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = r, u, -f
    m[:3, 3] = -m[:3, :3] @ np.asarray(eye, dtype=np.float64)
    return m


def perspective_matrix(fov: float, aspect: float, near: float, far: float) -> np.ndarray:
    """Eye to clip coordinates (OpenGL, depth -1..1), vertical field of view ``fov`` degrees."""
    t = 1.0 / math.tan(math.radians(fov) / 2.0)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = t / aspect, t
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2.0 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def pixel_matrix(width: int, height: int) -> np.ndarray:
    """Clip coordinates to homogeneous pixel coordinates: x from the left edge, y from the top edge
    (row 0 at the top), depth kept; a pixel's centre is at ``(col + 0.5, row + 0.5)``."""
    m = np.eye(4)
    m[0, 0], m[0, 3] = width / 2.0, width / 2.0
    m[1, 1], m[1, 3] = -height / 2.0, height / 2.0
    return m


def project(points, scene: dict, width: int, height: int) -> np.ndarray:
    """Pixel coordinates ``(N, 2)`` of world ``points`` (x from the left, y from the top) under the
    scene's camera: the matrices the peers are given, checked against dvr-gl's rays in the tests."""
    cam = scene["camera"]
    near, far = depth_range(scene)
    m = pixel_matrix(width, height) @ perspective_matrix(cam["fov"], width / height, near, far) @ view_matrix(
        cam["eye"], cam["target"], cam["up"])
    p = np.c_[np.asarray(points, dtype=np.float64), np.ones(len(points))] @ m.T
    return p[:, :2] / p[:, 3:4]


def box(scene: dict) -> tuple[np.ndarray, np.ndarray]:
    """The volume's box, the hull of its samples: ``origin`` to ``origin + (n - 1) * spacing``."""
    lo = np.asarray(scene["origin"], dtype=np.float64)
    return lo, lo + (np.asarray(scene["dims"]) - 1) * np.asarray(scene["spacing"], dtype=np.float64)


def depth_range(scene: dict, margin: float = 0.02) -> tuple[float, float]:
    """Near and far planes that hold the whole box (with a margin) in front of the eye."""
    lo, hi = box(scene)
    pad = margin * float(np.linalg.norm(hi - lo)) + 1e-6
    cam = scene["camera"]
    f, _, _ = camera_basis(cam["eye"], cam["target"], cam["up"])
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    depth = (corners - np.asarray(cam["eye"])) @ f
    far = float(depth.max()) + pad
    return max(float(depth.min()) - pad, far * 1e-4), far


def classify(points, values) -> np.ndarray:
    """The transfer function (control points ``[value, r, g, b, alpha]``) at ``values``: linear between
    points, constant beyond; ``(N, 4)`` colour and alpha, not premultiplied."""
    p = np.asarray(points, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    return np.stack([np.interp(v, p[:, 0], p[:, c]) for c in range(1, 5)], axis=-1)


def srgb_to_linear(x) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def from_framebuffer(pixels, bottom_up: bool = False, srgb: bool = False) -> np.ndarray:
    """A peer's framebuffer (``(H, W, 4)``, uint8 or float, premultiplied colour over a transparent
    black clear) as dvr-gl's image: float32 premultiplied linear RGBA, row 0 at the top.  ``srgb``:
    the colour channels were encoded to sRGB on the way out (decoded here; alpha is linear)."""
    a = np.asarray(pixels)
    a = a.astype(np.float64) / 255.0 if a.dtype == np.uint8 else a.astype(np.float64)
    if bottom_up:
        a = a[::-1]
    if srgb:
        a = np.concatenate([srgb_to_linear(a[..., :3]), a[..., 3:]], axis=-1)
    return np.ascontiguousarray(a, dtype=np.float32)


# --- the renderers: each builds its scene once; render() draws a frame and waits for it to finish;
#     read() returns the last frame as dvr-gl's image ---


class Peer:
    name = "peer"
    version = ""

    def __init__(self, scene: dict, size: tuple[int, int]):
        self.scene, self.size = scene, tuple(size)
        self.settings: dict = {}

    def render(self):
        raise NotImplementedError

    def read(self) -> np.ndarray:
        raise NotImplementedError

    def close(self):
        pass


def _headless_egl():
    """Without a display, Mesa's EGL must be told to use no window system at all."""
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("EGL_PLATFORM", "surfaceless")
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def _vtk_property(vtk, scene: dict):
    """The scene's transfer function as a ``vtkVolumeProperty`` (linear colour, alpha per unit distance)."""
    colour, opacity = vtk.vtkColorTransferFunction(), vtk.vtkPiecewiseFunction()
    colour.SetColorSpaceToRGB()
    for v, r, g, b, a in scene["transfer_function"]:
        colour.AddRGBPoint(v, r, g, b)
        opacity.AddPoint(v, a)
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(colour)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(scene["unit_distance"])
    return prop


def _vtk_offscreen(vtk, mapper, prop, scene: dict, clipping_range, size):
    """``(renderer, window, camera)``: the volume in an offscreen window with a transparent background and
    the scene's camera."""
    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    renderer = vtk.vtkRenderer()
    renderer.AddVolume(volume)
    renderer.SetBackground(0.0, 0.0, 0.0)
    renderer.SetBackgroundAlpha(0.0)
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(True)
    window.SetAlphaBitPlanes(True)
    window.SetMultiSamples(0)
    window.AddRenderer(renderer)
    cam = renderer.GetActiveCamera()
    c = scene["camera"]
    cam.SetPosition(*c["eye"])
    cam.SetFocalPoint(*c["target"])
    cam.SetViewUp(*c["up"])
    cam.SetViewAngle(c["fov"])
    cam.SetClippingRange(*clipping_range)
    window.SetSize(*size)
    return renderer, window, cam


class VtkPeer(Peer):
    """VTK's GPU ray caster (``vtkGPUVolumeRayCastMapper``) or its CPU one
    (``vtkFixedPointVolumeRayCastMapper``) in an offscreen EGL render window."""

    gpu = True

    def __init__(self, scene, size):
        super().__init__(scene, size)
        _headless_egl()
        import vtk
        from vtk.util import numpy_support

        self.vtk = vtk
        self.name = "vtk-gpu" if self.gpu else "vtk-cpu"
        self.version = vtk.vtkVersion.GetVTKVersion()
        data = np.load(scene["volume"])
        image = vtk.vtkImageData()
        image.SetDimensions(*scene["dims"])
        image.SetSpacing(*scene["spacing"])
        image.SetOrigin(*scene["origin"])
        scalars = numpy_support.numpy_to_vtk(np.ascontiguousarray(data).ravel(), deep=True)
        image.GetPointData().SetScalars(scalars)
        prop = _vtk_property(vtk, scene)
        prop.SetInterpolationTypeToLinear()
        prop.ShadeOff()
        if self.gpu:
            mapper = vtk.vtkGPUVolumeRayCastMapper()
            mapper.SetLockSampleDistanceToInputSpacing(False)
            mapper.SetUseJittering(False)
        else:
            mapper = vtk.vtkFixedPointVolumeRayCastMapper()
            mapper.SetInteractiveSampleDistance(scene["sample_distance"])
            mapper.SetMinimumImageSampleDistance(1.0)
            mapper.SetMaximumImageSampleDistance(1.0)
        mapper.SetInputData(image)
        mapper.SetAutoAdjustSampleDistances(False)
        mapper.SetSampleDistance(scene["sample_distance"])
        mapper.SetImageSampleDistance(1.0)
        if scene["mode"] == "mip":
            mapper.SetBlendModeToMaximumIntensity()
        else:
            mapper.SetBlendModeToComposite()
        self.renderer, self.window, self.camera = _vtk_offscreen(vtk, mapper, prop, scene, depth_range(scene),
                                                                 self.size)
        self.settings = {"mapper": mapper.GetClassName(), "sample_distance": mapper.GetSampleDistance(),
                         "image_sample_distance": mapper.GetImageSampleDistance(),
                         "auto_adjust_sample_distances": bool(mapper.GetAutoAdjustSampleDistances()),
                         "scalar_opacity_unit_distance": prop.GetScalarOpacityUnitDistance(),
                         "window": self.window.GetClassName()}

    def render(self):
        self.window.Render()
        self.window.WaitForCompletion()

    def read(self) -> np.ndarray:
        from vtk.util import numpy_support

        w, h = self.size
        out = self.vtk.vtkUnsignedCharArray()
        self.window.GetRGBACharPixelData(0, 0, w - 1, h - 1, 0, out)
        pixels = numpy_support.vtk_to_numpy(out).reshape(h, w, 4)
        return from_framebuffer(pixels, bottom_up=True)

    def close(self):
        self.window.Finalize()


class VtkCpuPeer(VtkPeer):
    gpu = False


class VtkTetraPeer(Peer):
    """VTK's ``vtkProjectedTetrahedraMapper`` on a mesh (``dvr bench cells``): the scene's ``mesh`` is a
    ``.vtu`` of tetrahedra with the scalar ``scalars`` (point or cell data).  Each frame marks the
    camera modified, so VTK sorts the cells again, as dvr-gl does every frame."""

    def __init__(self, scene, size):
        super().__init__(scene, size)
        _headless_egl()
        import vtk

        self.vtk = vtk
        self.name = "vtk-pt"
        self.version = vtk.vtkVersion.GetVTKVersion()
        reader = vtk.vtkXMLUnstructuredGridReader()
        reader.SetFileName(scene["mesh"])
        reader.Update()
        grid = reader.GetOutput()
        data = grid.GetPointData() if grid.GetPointData().HasArray("scalars") else grid.GetCellData()
        data.SetActiveScalars("scalars")
        prop = _vtk_property(vtk, scene)
        prop.ShadeOff()
        mapper = vtk.vtkProjectedTetrahedraMapper()
        mapper.SetInputData(grid)
        self.renderer, self.window, self.camera = _vtk_offscreen(vtk, mapper, prop, scene, scene["clipping_range"],
                                                                 self.size)
        self.settings = {"mapper": mapper.GetClassName(), "cells": grid.GetNumberOfCells(),
                         "scalar_opacity_unit_distance": prop.GetScalarOpacityUnitDistance(),
                         "window": self.window.GetClassName()}

    def render(self):
        self.camera.Modified()  # sort again, as every frame of an interactive view does
        self.window.Render()
        self.window.WaitForCompletion()

    read = VtkPeer.read

    def close(self):
        self.window.Finalize()


class VispyPeer(Peer):
    """vispy's Volume visual on an offscreen EGL canvas, under a camera that applies the scene's
    view and projection matrices as they are."""

    def __init__(self, scene, size):
        super().__init__(scene, size)
        _headless_egl()
        import vispy

        vispy.use(app="egl")
        from vispy import scene as vscene
        from vispy.color import Colormap
        from vispy.scene.cameras import BaseCamera
        from vispy.visuals.transforms import MatrixTransform, STTransform

        self.version = vispy.__version__
        self.name = "vispy"
        peer = self

        class SceneCamera(BaseCamera):  # the scene's camera, exactly (vispy's own cameras orbit their own way)
            def _update_transform(self, event=None):
                if self._viewbox is None:
                    return
                w, h = self._viewbox.size
                if w == 0 or h == 0:
                    return
                c, (near, far) = peer.scene["camera"], depth_range(peer.scene)
                m = pixel_matrix(w, h) @ perspective_matrix(c["fov"], w / h, near, far) @ view_matrix(
                    c["eye"], c["target"], c["up"])
                self._set_scene_transform(MatrixTransform(m.T))  # vispy multiplies row vectors

        data = np.load(scene["volume"])
        if data.dtype == np.int16:  # vispy has no texture format for int16 ("auto" raises): float32, as a user would
            data = data.astype(np.float32)
        points = scene["transfer_function"]
        lo, hi = scene["value_range"]
        # vispy's colour map spans the value range exactly: the TF at both ends and its points between
        # (piecewise linear, so nothing is lost)
        values = np.array([lo] + [p[0] for p in points if lo < p[0] < hi] + [hi], dtype=np.float64)
        colormap = Colormap(classify(points, values), controls=(values - lo) / (hi - lo), interpolation="linear")
        self.canvas = vscene.SceneCanvas(size=self.size, show=False, bgcolor=(0, 0, 0, 0))
        view = self.canvas.central_widget.add_view(border_width=0)
        dims = np.asarray(scene["dims"], dtype=np.float64)
        # vispy's volume box runs from -0.5 to n - 0.5 voxels; six clipping planes (in the visual's voxel
        # coordinates) cut it to the hull of the samples, dvr-gl's box
        planes = [[[0.0, 0.0, 0.0], list(n)] for n in np.eye(3)]
        planes += [[list(dims - 1.0), list(-n)] for n in np.eye(3)]
        spacing = np.asarray(scene["spacing"], dtype=np.float64)
        step = scene["sample_distance"] / float(spacing.min())  # vispy steps in voxels
        self.volume = vscene.visuals.Volume(
            data, parent=view.scene, clim=(lo, hi), method="mip" if scene["mode"] == "mip" else "translucent",
            relative_step_size=step, cmap=colormap, interpolation="linear", texture_format="auto",
            clipping_planes=np.asarray(planes), clipping_planes_coord_system="visual")
        self.volume.transform = STTransform(scale=spacing, translate=scene["origin"])
        # vispy's translucent blending keeps the framebuffer's alpha (the clear value): add the coverage
        # as a compositor would, colour unchanged
        self.volume.set_gl_state("translucent", cull_face=False,
                                 blend_func=("src_alpha", "one_minus_src_alpha", "one", "one_minus_src_alpha"))
        view.camera = SceneCamera(interactive=False)
        self.image = None
        self.settings = {"method": self.volume.method, "relative_step_size": step, "interpolation": "linear",
                         "texture_format": "auto", "data": str(data.dtype),
                         "clipping_planes": "the hull of the samples",
                         "colormap": "the transfer function's points, alpha per sample"}

    def render(self):
        # draws into an offscreen framebuffer and reads it back (8 bits): one call, finished
        self.image = self.canvas.render(alpha=True)

    def read(self) -> np.ndarray:
        return from_framebuffer(self.image)

    def close(self):
        self.canvas.close()


class PygfxPeer(Peer):
    """pygfx's ray-cast volume material (MIP only: pygfx has no emission-absorption material) on an
    offscreen wgpu canvas (Vulkan: lavapipe on a machine without a GPU)."""

    def __init__(self, scene, size):
        super().__init__(scene, size)
        if scene["mode"] != "mip":
            raise Unsupported("pygfx has no emission-absorption volume material (MIP, MinIP, iso, slice)")
        import pygfx as gfx
        import wgpu

        self.gfx = gfx
        self.name, self.version = "pygfx", f"{gfx.__version__} (wgpu {wgpu.__version__})"
        data = np.load(scene["volume"])
        lo, hi = scene["value_range"]
        n = 256  # the colour map's texels cover [lo, hi] at their centres
        table = classify(scene["transfer_function"], lo + (np.arange(n) + 0.5) / n * (hi - lo)).astype(np.float32)
        # clamped: pygfx's default wrap (repeat) would show the colour map's start at the top of clim
        colormap = gfx.TextureMap(gfx.Texture(table, dim=1, colorspace="physical"), filter="linear", wrap="clamp")
        material = gfx.VolumeMipMaterial(clim=(lo, hi), map=colormap, interpolation="linear", alpha_mode="blend")
        self.volume = gfx.Volume(gfx.Geometry(grid=gfx.Texture(np.ascontiguousarray(data), dim=3)), material)
        self.volume.local.scale = tuple(scene["spacing"])
        self.volume.local.position = tuple(scene["origin"])
        self.world = gfx.Scene()
        self.world.add(self.volume)
        self.device_info = dict(wgpu.gpu.request_adapter_sync().info)
        self._build(size)
        self.settings = {"material": "VolumeMipMaterial", "interpolation": "linear", "pixel_scale": 1,
                         "pixel_filter": "nearest", "ppaa": "none", "colormap": "physical (linear) colours",
                         "adapter": self.device_info.get("device", "")}

    def _build(self, size):
        from rendercanvas.offscreen import RenderCanvas

        gfx, c = self.gfx, self.scene["camera"]
        self.size = tuple(size)
        self.canvas = RenderCanvas(size=self.size, pixel_ratio=1)  # sizes the renderer's target; never drawn
        self.renderer = gfx.WgpuRenderer(self.canvas, pixel_scale=1, pixel_filter="nearest", ppaa="none")
        near, far = depth_range(self.scene)
        self.camera = gfx.PerspectiveCamera(c["fov"], self.size[0] / self.size[1], depth_range=(near, far))
        self.camera.local.position = tuple(c["eye"])
        self.camera.world.reference_up = tuple(c["up"])
        self.camera.look_at(tuple(c["target"]))

    def render(self):
        # into the renderer's own colour target (premultiplied, sRGB-encoded 8 bits), cleared each frame
        # (without a flush pygfx would blend onto the last one), read back: the read-back is what waits
        # for the frame; the canvas's present pass is skipped (it applied the alpha a second time)
        self.renderer.render(self.world, self.camera, flush=False, clear=True)
        self.image = self.renderer.snapshot()

    def read(self) -> np.ndarray:
        return from_framebuffer(self.image, srgb=True)


class NumpyPeer(Peer):
    """A small CPU ray caster in numpy with the worker's camera and box helpers: the stub peer of the
    tests (tiny sizes only), and a check that the helpers describe dvr-gl's scene."""

    name = "numpy"

    def __init__(self, scene, size):
        super().__init__(scene, size)
        self.version = np.__version__
        self.data = np.load(scene["volume"]).astype(np.float64)
        self.settings = {"sample_distance": scene["sample_distance"]}
        self.image = None

    def _sample(self, p):
        """Trilinear interpolation at world points ``p`` (inside the box)."""
        s = self.scene
        g = (p - np.asarray(s["origin"])) / np.asarray(s["spacing"])
        dims = np.asarray(s["dims"])
        g = np.clip(g, 0, dims - 1)
        i0 = np.minimum(np.floor(g).astype(int), np.maximum(dims - 2, 0))
        t = g - i0
        out = 0.0
        for dz in (0, 1):
            for dy in (0, 1):
                for dx in (0, 1):
                    idx = np.minimum(i0 + [dx, dy, dz], dims - 1)
                    w = (np.where(dx, t[:, 0], 1 - t[:, 0]) * np.where(dy, t[:, 1], 1 - t[:, 1])
                         * np.where(dz, t[:, 2], 1 - t[:, 2]))
                    out = out + w * self.data[idx[:, 2], idx[:, 1], idx[:, 0]]
        return out

    def render(self):
        s, (w, h) = self.scene, self.size
        c = s["camera"]
        f, r, u = camera_basis(c["eye"], c["target"], c["up"])
        half_h = math.tan(math.radians(c["fov"]) / 2.0)
        x = ((np.arange(w) + 0.5) / w * 2.0 - 1.0) * half_h * w / h
        y = (1.0 - (np.arange(h) + 0.5) / h * 2.0) * half_h
        xx, yy = np.meshgrid(x, y)
        d = f + xx.reshape(-1, 1) * r + yy.reshape(-1, 1) * u
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        eye = np.asarray(c["eye"], dtype=np.float64)
        lo, hi = box(s)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_a, t_b = (lo - eye) / d, (hi - eye) / d
        t0 = np.nanmax(np.minimum(t_a, t_b), axis=1).clip(0)
        t1 = np.nanmin(np.maximum(t_a, t_b), axis=1)
        step = s["sample_distance"]
        n = np.where(t1 > t0, np.ceil((t1 - t0) / step), 0).astype(int)
        colour, alpha = np.zeros((w * h, 3)), np.zeros(w * h)
        peak = np.full(w * h, -np.inf)
        for k in range(int(n.max(initial=0))):
            live = k < n
            a, b = t0 + k * step, np.minimum(t0 + (k + 1) * step, t1)
            mid = eye + d * ((a + b) / 2)[:, None]
            values = self._sample(mid[live])
            if s["mode"] == "mip":
                peak[live] = np.maximum(peak[live], values)
                continue
            rgba = classify(s["transfer_function"], values)
            sigma = -np.log1p(-np.minimum(rgba[:, 3], 1 - 2 ** -24)) / s["unit_distance"]
            opacity = -np.expm1(-sigma * (b - a)[live])
            weight = (1 - alpha[live]) * opacity
            colour[live] += weight[:, None] * rgba[:, :3]
            alpha[live] += weight
        if s["mode"] == "mip":
            hit = np.isfinite(peak)
            rgba = classify(s["transfer_function"], peak[hit])
            alpha[hit] = np.minimum(rgba[:, 3], 1 - 2 ** -24)
            colour[hit] = rgba[:, :3] * alpha[hit, None]
        self.image = np.concatenate([colour, alpha[:, None]], axis=1).reshape(h, w, 4).astype(np.float32)

    def read(self):
        return self.image


class DvrGlPeer(Peer):
    """dvr-gl itself (the job's scene keys, in dvr-gl's interpreter), timed like the peers."""

    name = "dvr-gl"

    def __init__(self, scene, size, overrides: dict):
        super().__init__(scene, size)
        import dvr_gl
        from dvr_gl.renderers import create_renderer
        from dvr_gl.scene.resolve import load_scene

        self.version = dvr_gl.__version__ if hasattr(dvr_gl, "__version__") else ""
        self.scene_ = load_scene(None, {**overrides, "image.width": size[0], "image.height": size[1]})
        self.renderer = create_renderer(self.scene_.renderer.name)
        r = self.scene_.renderer
        self.settings = {"renderer": r.name,
                         "sample_distance_voxels": r.sample_distance / self.scene_.volume.spacing[0]}
        for key in ("ert_threshold", "acceleration", "classification", "filter", "tolerance", "extremum_refinement",
                    "extremum_brackets"):
            if hasattr(r, key):
                self.settings[key] = getattr(r, key)
        self.image = None

    def render(self):
        self.image = self.renderer.render(self.scene_)  # draws, finishes and reads the float image back

    def read(self):
        return self.image

    def close(self):
        self.renderer.close()


class Unsupported(Exception):
    """The peer cannot render this scene (written to result.json, not an error of the run)."""


PEERS = {"vtk-gpu": VtkPeer, "vtk-cpu": VtkCpuPeer, "vispy": VispyPeer, "pygfx": PygfxPeer, "numpy": NumpyPeer,
         "vtk-pt": VtkTetraPeer}
#: What each peer needs importable (``dvr bench peers`` asks the peers' interpreter for these).
MODULES = {"vtk-gpu": "vtk", "vtk-cpu": "vtk", "vispy": "vispy", "pygfx": "pygfx", "numpy": "numpy", "vtk-pt": "vtk"}


def run(job: dict) -> dict:
    out = Path(job["out"])
    scene, size = job["scene"], tuple(job["size"])
    name = job["renderer"]
    create = (lambda size: DvrGlPeer(scene, size, job["dvrgl"])) if name == "dvr-gl" else (
        lambda size: PEERS[name](scene, size))
    start = time.perf_counter()
    try:
        peer = create(size)
    except Unsupported as exc:
        return {"renderer": name, "unsupported": str(exc)}
    try:
        peer.render()  # uploads, programs, tables: not timed
        first = time.perf_counter() - start
        seconds = []
        for _ in range(job["frames"]):
            t = time.perf_counter()
            peer.render()
            seconds.append(time.perf_counter() - t)
        if job.get("save_image"):
            np.save(out / "image.npy", peer.read())
        result = {"renderer": name, "version": peer.version, "seconds": seconds, "first_seconds": first,
                  "settings": peer.settings}
    finally:
        peer.close()
    if job.get("error_size"):  # the same renderer built anew at the error size (untimed)
        small = create(tuple(job["error_size"]))
        try:
            small.render()
            np.save(out / "error.npy", small.read())
        finally:
            small.close()
    return result


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    job = json.loads(Path(argv[0]).read_text())
    result = run(job)
    Path(job["out"], "result.json").write_text(json.dumps(result, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
