"""dvr-gl: direct volume rendering in Python on OpenGL, checked against a float64 CPU reference."""

__version__ = "0.1.0"
