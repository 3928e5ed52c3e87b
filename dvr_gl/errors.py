"""User-facing errors.

Every problem a user can cause or fix (bad input file, bad scene key, no GL
context, unwritable output) raises :class:`DvrError` with a one-line message
that names the problem and what to do.  The CLI prints that line and exits
non-zero; everything else is a bug and keeps its traceback.
"""


def install_hint(extra: str) -> str:
    """How to install the optional extra ``extra`` (``"video"``, ``"plot"``, ...), in words every message
    shares: from a checkout of the repository (how dvr-gl is installed today) or from a package index."""
    return f"pip install -e '.[{extra}]' in the dvr-gl checkout (or pip install 'dvr-gl[{extra}]')"


class DvrError(Exception):
    """A problem with the user's input or environment, explained in one line."""

    def __init__(self, message: str):
        # Collapse to one line: messages from libraries sometimes carry newlines.
        super().__init__(" ".join(str(message).split()))


class VolumeError(DvrError):
    """A volume file or array that cannot be used (wrong size, type, NaN, ...)."""


class SceneError(DvrError):
    """A scene file or override with an unknown key or an invalid value."""


class GLUnavailableError(DvrError):
    """No OpenGL context could be created."""


class ShaderError(DvrError):
    """A GLSL program failed to compile or link."""
