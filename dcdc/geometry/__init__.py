"""Geometry: signed distance functions of walls and obstacles, and particle sampling.

Walls are described by a signed distance function (SDF) of the *solid* (negative inside the
solid, positive in the fluid space). :func:`sample_walls` turns any SDF into boundary
particles with normals (∇SDF, pointing into the fluid); :func:`fill_region` samples fluid on
the rest lattice. Built-in shapes live in :mod:`dcdc.geometry.shapes`.
"""
from .sampling import fill_box, fill_region, lattice, sample_walls, sdf_normals  # noqa: F401
