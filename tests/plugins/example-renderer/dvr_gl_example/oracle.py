"""The example's oracle, where every renderer keeps it (``oracle.py``, ``oracle(scene)``): dvr-gl's shared
same-discretization judge as it is, since the renderer samples where dvr-gl's conventions put the samples
(segments of the sample distance from each ray's entry) and classifies through the same table."""

from dvr_gl.reference.discrete import same_discretization


def oracle(scene):
    """The float64 image ``(H, W, 4)`` the renderer must match to float32 rounding."""
    return same_discretization(scene)
