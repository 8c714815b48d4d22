"""Test-session setup: the OpenMP wait policy dcdc sets on import, set before any test module
imports torch (dcdc warns when torch was loaded first without it)."""
import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
