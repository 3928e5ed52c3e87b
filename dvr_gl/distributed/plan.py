"""What sort-last rendering of a scene needs before any worker starts: whether the scene can be
composited from partial images at all (one line if not), the bricks, their split among workers
(:mod:`.kd`) and the workers' visibility order for the scene's view."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..orientation import volume_frame_scene
from ..renderers import registry
from . import kd
from .composite import operator_of

METHODS = ("direct_send", "binary_swap")


def check_scene(scene) -> None:
    """One line for a scene whose image is not the composite of its bricks' partial images."""
    r = scene.renderer
    if not registry.plugin(r.name).sort_last:
        others = registry.renderers_with(lambda p: p.sort_last)
        raise SceneError(f"distributed rendering composites partial images of the volume's bricks; renderer "
                         f"{r.name!r} makes none: use renderer {' or '.join(others)}")
    if getattr(r, "geometry", None):
        raise SceneError("distributed rendering with [[renderer.geometry]]: the meshes end the rays before "
                         "the bricks are composited (each worker would need every mesh's depth); "
                         "render the meshes in one process (no --dask)")
    scattering = getattr(r, "scattering", None)
    if scattering is not None and getattr(scattering, "enabled", False):
        raise SceneError("distributed rendering with renderer.scattering: a brick's light depends on every "
                         "brick between it and the lights; render scattering in one process (no --dask)")


def check_method(method: str, workers: int) -> None:
    if method not in METHODS:
        raise SceneError(f"compositing method {method!r}: use one of {', '.join(METHODS)}")
    if method == "binary_swap" and workers & (workers - 1):
        raise SceneError(f"binary swap pairs workers in log2(N) rounds and needs a power-of-two number of "
                         f"workers, got {workers}: use {2 ** int(math.log2(workers))} workers or "
                         f"--compositing-method direct_send")


@dataclass
class Plan:
    """The bricks of each worker, the kd tree, the workers in visibility order, the operator."""

    root: kd.Node
    bricks: list          # per worker: its bricks (possibly none)
    order: list           # worker numbers, front first
    operator: str
    front_first: object   # front_first(lo, mid, hi) -> is workers [lo, mid) in front of [mid, hi)?


def bricks_for(renderer, scene, workers: int) -> list:
    """The bricks: the texture budget's, or smaller ones until there are at least two per worker
    (so that the kd split can give every worker a box; fewer, smaller bricks cost passes)."""
    bricks = renderer.brick_plan(scene)
    edge = max(max(b.tex_dims) for b in bricks)
    while len(bricks) < 2 * workers and workers > 1:
        edge = int(edge * 0.8)
        try:
            smaller = renderer.brick_plan(scene, edge)
        except ValueError:  # no core left beside the ghosts: as small as they go
            break
        bricks = smaller if len(smaller) > len(bricks) else bricks
    return bricks


def plan(renderer, scene, workers: int) -> Plan:
    check_scene(scene)
    root, assigned = kd.split(bricks_for(renderer, scene, workers), workers)
    local, _ = volume_frame_scene(scene)  # bricks and the kd planes are in the volume's own frame
    volume, camera = local.volume, local.camera
    eye = (np.asarray(camera.eye) - np.asarray(volume.origin)) / np.asarray(volume.spacing)
    forward = camera.basis()[0] / np.asarray(volume.spacing)
    ortho = camera.projection == "orthographic"
    order = kd.front_to_back(root, eye, forward, ortho)

    def front_first(lo, mid, hi):
        node = kd.sibling_node(root, lo, hi)
        return node.left is None or node.left_first(eye, forward, ortho)

    r = scene.renderer
    brackets = 2 if getattr(r, "extremum_refinement", None) and getattr(r, "extremum_brackets", None) == 2 else 1
    return Plan(root, assigned, order, operator_of(r.compositing, getattr(r, "order", "front_to_back"), brackets),
                front_first)
