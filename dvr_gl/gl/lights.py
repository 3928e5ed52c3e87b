"""The uniforms of ``dvr_gl/gl/shaders/common/shading.glsl``: Blinn-Phong coefficients and the lights."""

from __future__ import annotations

import numpy as np


def shading_uniforms(shading) -> dict:
    """``[renderer.shading]``'s coefficients, and per light ``u_light_dir`` (a headlight: ``(0, 0, 0, 1)``,
    the shader takes the view direction; a directional light: the unit vector toward it, w 0) and
    ``u_light_color``; no light arrays without lights (the shader has none)."""
    u = {"u_ambient": shading.ambient, "u_diffuse": shading.diffuse, "u_specular": shading.specular,
         "u_shininess": shading.shininess}
    if shading.lights:
        u["u_light_dir"] = [(0.0, 0.0, 0.0, 1.0) if light.type == "headlight" else
                            (*(-np.asarray(light.direction) / np.linalg.norm(light.direction)), 0.0)
                            for light in shading.lights]
        u["u_light_color"] = [tuple(light.color) for light in shading.lights]
    return u


def set_uniform(program, name, value):
    """Set a uniform by its Python value; one the program lacks (compiled out) is skipped.  Lists are
    uniform arrays (packed float32), tuples vectors (int or float by the uniform's type); an array the
    compiler shortened (only its first elements read, e.g. at constant indices) takes those first elements."""
    if name not in program:
        return
    uniform = program[name]
    if isinstance(value, list):
        data = np.asarray(value, dtype=np.float32).ravel()
        uniform.write(data[:uniform.array_length * uniform.dimension].tobytes())
    elif isinstance(value, (tuple, np.ndarray)):
        uniform.value = tuple(int(x) if uniform.fmt.endswith("i") else float(x) for x in value)
    else:
        uniform.value = value
