"""The learned simulator: CConv operator, density-conditioned layers, networks, integrator.

Modules: ``cconv`` (operator, geometry, autograd), ``modulation`` (eqs. 4–5), ``layers``,
``networks`` (registry, ``build_network``), ``integrator`` (Algorithm 1), ``checkpoint``,
``benchmark`` (``dcdc benchmark cconv|model``). See docs/model.md.

Threading: the CConv path alternates numba kernels and torch GEMMs, i.e. two OpenMP
runtimes (numba's and torch's bundled one). With OpenMP's default *active* wait policy the
idle pool spins and starves the other; on a shared 2-core machine that cost 10–200× (a
16-particle forward took 250 ms instead of 1.5 ms). ``OMP_WAIT_POLICY=PASSIVE`` fixes it,
but is read only when an OpenMP runtime loads, so it is set here — before this package
imports torch — unless the user chose a policy. If torch was imported earlier, export it in
the shell instead.
"""
import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
