"""Trajectory datasets: HDF5 layout, reader and integrity checks (:mod:`.dataset`),
generation (:mod:`.generate`, its worker pool :mod:`.pool`, clean Ctrl-C/SIGTERM
:mod:`.interrupt`), output paths checked first and written atomically (:mod:`.outputs`),
LagrangeBench export (:mod:`.lagrangebench`). docs/datasets.md."""
from .dataset import Dataset, Trajectory, merge, write_trajectory  # noqa: F401
