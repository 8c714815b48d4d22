"""dcdc: Density-Conditioned Dynamic Convolution for multiphase particle fluids.

```python
import dcdc
scene = dcdc.load_scene("lock_exchange")          # built-in name, .toml path or TOML text
truth = dcdc.run_sph(scene, dim=2, duration=1.0)  # the multiphase SPH solver
pred = dcdc.simulate(dcdc.load_model("dcdc2d"), scene, dim=2, steps=50)
```
(docs/api.md; the functions load lazily, so ``import dcdc`` stays fast.)

Data flow (one module per arrow, see ``docs/``)::

    scene file -> particles -> SPH solver -> dataset (HDF5) -> model -> training
               -> neural rollout -> metrics -> render / export

Threading defaults, set here so that every entry point gets them before numba or torch
start a thread pool (an explicit setting in the environment always wins):

* ``OMP_WAIT_POLICY=PASSIVE``: the model alternates numba kernels and torch GEMMs, two
  OpenMP runtimes; with the default active wait the idle pool spins and starves the other
  (measured on 2 cores: a 16-particle forward took 250 ms instead of 1.5 ms).
  OpenMP reads the policy when torch loads: a program that imports torch before dcdc
  without it set gets a warning (a 3-D rollout on 2 cores: 1.2-1.3x the wall time).
* numba's ``workqueue`` threading layer: the OpenMP layer spin-waits at every parallel
  region; on a shared 2-core machine one neighbour pass took 11.6 ms with 2 threads and
  1.0 ms with workqueue (10 k particles).
"""
import os as _os
import sys as _sys

if "OMP_WAIT_POLICY" not in _os.environ:
    _os.environ["OMP_WAIT_POLICY"] = "PASSIVE"
    if "torch" in _sys.modules:  # its OpenMP runtime has read the default already
        import warnings as _warnings

        _warnings.warn("torch was imported before dcdc, so its OpenMP threads spin while "
                       "dcdc's numba kernels run (slower rollouts and training); import dcdc "
                       "first or set OMP_WAIT_POLICY=PASSIVE before Python starts",
                       RuntimeWarning, stacklevel=2)
if "NUMBA_THREADING_LAYER" not in _os.environ:
    _os.environ["NUMBA_THREADING_LAYER"] = "workqueue"
    if "numba" in _sys.modules:  # imported before dcdc: set its config directly
        _sys.modules["numba"].config.THREADING_LAYER = "workqueue"

from .version import __version__  # noqa: E402

_API = ("Run", "load_scene", "load_model", "run_sph", "rollout", "simulate")
_SUBPACKAGES = ("api", "data", "evaluate", "geometry", "metrics", "model", "render", "scene",
                "sph", "train")
__all__ = [*_API, "__version__"]


def __getattr__(name):
    """``dcdc.load_scene`` etc. (:mod:`dcdc.api`) and ``dcdc.sph`` etc., imported on first use."""
    import importlib
    if name in _API:
        return getattr(importlib.import_module(".api", __name__), name)
    if name in _SUBPACKAGES:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'dcdc' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API) | set(_SUBPACKAGES))
