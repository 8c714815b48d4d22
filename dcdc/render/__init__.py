"""Seeing results: pictures, animations, exports and a browser viewer of trajectories.

* :mod:`.camera`, :mod:`.splat`, :mod:`.frames`, :mod:`.overlay`, :mod:`.video`: the
  ``dcdc render`` rasteriser (shaded sphere impostors in a z-buffer) and its outputs;
* :mod:`.compare`: the error between two trajectories shown by ``render --compare``;
* :mod:`.export`: PLY / VTK / VTU + PVD files for Blender and ParaView (``dcdc export``);
* :mod:`.view`: one self-contained WebGL HTML page (``dcdc view``);
* :mod:`.figures`: animations, strips and comparisons (also :func:`snapshot_strip` and
  :func:`animate` for Python callers such as ``dcdc demo``).

The side views of ``dcdc scene show`` are :mod:`dcdc.scene.draw`'s.
"""
from .figures import animate, snapshot_strip  # noqa: F401
