"""dcdc: Density-Conditioned Dynamic Convolution for multiphase particle fluids.

Data flow (one module per arrow, see ``docs/`` and ``../shared/DESIGN.md`` §1)::

    scene file -> particles -> SPH solver -> dataset (HDF5) -> model -> training
               -> neural rollout -> metrics -> render / export
"""
__version__ = "0.1.0"
