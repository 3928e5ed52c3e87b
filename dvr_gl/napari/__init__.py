"""The napari plugin (npe2 manifest ``napari.yaml``, extra ``napari``; docs/napari.md).

* :mod:`.scene`: napari's viewer as a dvr-gl :class:`~dvr_gl.Scene` (camera, layers' geometry, colormaps,
  contrast limits, gamma, opacity, label colours) and :func:`~.scene.render_view`, the picture of it;
* :mod:`.widget`: the dock widget (Qt) that renders the current 3D view into a new layer, a file or an
  orbit/time animation;
* :mod:`.readers`: readers for the formats napari lacks (NRRD, MetaImage, DICOM series, VTK, meshes).

Nothing here imports napari or Qt at import time: the manifest names the functions, napari imports them.
"""
