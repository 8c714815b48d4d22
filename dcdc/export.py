"""Kept for old imports: the point-cloud writers live in :mod:`dcdc.render.export`."""
from .render.export import WRITERS, write_ply, write_points, write_vtk  # noqa: F401
