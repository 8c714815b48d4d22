"""The learned simulator: CConv operator, density-conditioned layers, networks, integrator.

Modules: ``cconv`` (operator, geometry, autograd), ``modulation`` (eqs. 4–5), ``layers``,
``networks`` (registry, ``build_network``), ``integrator`` (Algorithm 1), ``checkpoint``,
``benchmark`` (``dcdc benchmark cconv|model``). See docs/model.md.

Threading defaults (``OMP_WAIT_POLICY=PASSIVE``, why) are set in :mod:`dcdc`.
"""
