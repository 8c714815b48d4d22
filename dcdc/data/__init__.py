"""Trajectory datasets: HDF5 layout and reader (:mod:`.dataset`), generation
(:mod:`.generate`), LagrangeBench export (:mod:`.lagrangebench`). docs/datasets.md."""
from .dataset import Dataset, Trajectory, merge, write_trajectory  # noqa: F401
