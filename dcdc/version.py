"""The package version (pyproject.toml's ``version``), recorded in every checkpoint."""
__version__ = "0.1.0"
