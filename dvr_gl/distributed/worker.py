"""What runs in a Dask worker process: one renderer per process and renderer name (its EGL context
created on the first task and kept for the next ones; only renderers that composite sort-last come
here), the scene reloaded once per payload, and the small steps of compositing (a band of rows cut
from a state, states combined).

A scene reaches the workers as a *payload*: ``(token, "dict", scene_dict, base_dir)`` for a scene
whose volume is a file (the worker reads the file itself; only the scene's few kilobytes travel)
or ``(token, "pickle", bytes)`` for a scene built in Python (arrays, the demos, volumes read out of
core, which pickle without their voxels and reopen their file).  ``token`` (a hash of the payload)
keys the worker's cache, so the frames of an animation load their scene once per worker."""

from __future__ import annotations

import hashlib
import pickle
import threading
from collections import OrderedDict
from pathlib import Path

import numpy as np

from .composite import combine_all, empty_state

_LOCK = threading.Lock()  # one GL context per process: its tasks draw one at a time
_RENDERERS: dict = {}  # renderer name -> this process's renderer
_SCENES: OrderedDict = OrderedDict()
_KEEP_SCENES = 2


def payload_of(scene) -> tuple:
    """The scene as the workers receive it (see the module doc)."""
    source = scene.volume_source
    if source.path and not getattr(scene.field, "out_of_core", False):
        from ..errors import SceneError

        try:
            data = scene.to_dict()
        except SceneError:
            data = None
        if data is not None:
            data["volume"]["path"] = str(Path(source.path).expanduser().resolve())
            body = ("dict", data, str(Path.cwd()))
            return (hashlib.sha1(pickle.dumps(body)).hexdigest(), *body)
    body = ("pickle", dumps(scene))
    return (hashlib.sha1(body[1]).hexdigest(), *body)


def dumps(scene) -> bytes:
    """The scene pickled (its ``[renderer]`` dataclass, built at run time, pickles as its fields:
    :func:`dvr_gl.renderers.registry.renderer_spec_class`)."""
    return pickle.dumps(scene, protocol=pickle.HIGHEST_PROTOCOL)


def scene_of(payload):
    """The payload's scene, loaded once per worker process (the last few kept)."""
    token, kind, *rest = payload
    scene = _SCENES.get(token)
    if scene is None:
        if kind == "dict":
            from ..scene.resolve import parse_scene, resolve_scene

            data, base_dir = rest
            scene = resolve_scene(parse_scene(data, None, base_dir), base_dir)
        else:
            scene = pickle.loads(rest[0])
        _SCENES[token] = scene
        while len(_SCENES) > _KEEP_SCENES:
            _SCENES.popitem(last=False)
    _SCENES.move_to_end(token)
    return scene


def renderer(name: str):
    """This process's renderer ``name`` (created on first use)."""
    if name not in _RENDERERS:
        from ..renderers import registry

        _RENDERERS[name] = registry.plugin(name).create()
    return _RENDERERS[name]


def render_part(payload, bricks: list, operator: str) -> tuple:
    """``(state, seconds)``: the compositing state of ``bricks`` (none: the empty state) and the
    time the renderer took."""
    with _LOCK:
        scene = scene_of(payload)
        if not bricks:
            return empty_state(operator, scene.image.height, scene.image.width), 0.0
        r = renderer(scene.renderer.name)
        state = r.render_state(scene, bricks)
        return state, float(r.stats.get("seconds", 0.0))


def render_frame(payload, camera) -> tuple:
    """``(image, seconds)``: a whole frame of the payload's scene seen by ``camera``."""
    with _LOCK:
        scene = scene_of(payload)
        if camera is not None:
            scene = scene.replace(camera=camera)
        r = renderer(scene.renderer.name)
        image = r.render(scene)
        return image, float(r.stats.get("seconds", 0.0))


def state_of(part):
    return part[0] if isinstance(part, tuple) else part


def rows(part, lo: int, hi: int) -> np.ndarray:
    """Rows ``lo .. hi - 1`` of a state (a copy: only these bytes travel)."""
    return np.ascontiguousarray(state_of(part)[lo:hi])


def composite(operator: str, *states) -> np.ndarray:
    """States in visibility order (front first) combined."""
    return combine_all(operator, [state_of(s) for s in states])


def swap(operator: str, mine, lo: int, hi: int, theirs, mine_in_front: bool) -> np.ndarray:
    """Binary swap's step: rows ``lo .. hi - 1`` of this worker's tile combined with the partner's
    rows of the same band."""
    own = state_of(mine)[lo:hi]
    return combine_all(operator, [own, theirs] if mine_in_front else [theirs, own])
