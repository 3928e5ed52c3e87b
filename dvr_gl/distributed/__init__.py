"""Rendering on a Dask cluster (the optional extra ``dask``): sort-last rendering of one frame's
bricks with direct send or binary swap compositing (:mod:`.sort_last`), and an animation's frames
one per task (:mod:`.frames`).  docs/distributed.md describes both, the bound with early ray
termination and the scaling model."""

from .cluster import connect, transfers, workers_of
from .composite import combine, combine_all, operator_of
from .frames import render_frames
from .plan import METHODS, check_method, check_scene
from .sort_last import Result, render

__all__ = ["METHODS", "Result", "check_method", "check_scene", "combine", "combine_all", "connect", "operator_of",
           "render", "render_frames", "transfers", "workers_of"]
