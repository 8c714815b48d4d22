"""dcdc sets OMP_WAIT_POLICY=PASSIVE on import, and warns when torch was imported first
without it (OpenMP read the active default when torch loaded)."""
import os
import subprocess
import sys


def _run(code: str, policy: str | None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if policy is not None:
        env["OMP_WAIT_POLICY"] = policy
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=120)


def test_torch_first_without_a_policy_warns_and_dcdc_first_does_not():
    r = _run("import torch\nimport dcdc\nimport os\nprint(os.environ['OMP_WAIT_POLICY'])", None)
    assert r.returncode == 0, r.stderr
    assert "torch was imported before dcdc" in r.stderr and r.stdout.strip() == "PASSIVE"
    r = _run("import dcdc\nimport torch\nimport os\nprint(os.environ['OMP_WAIT_POLICY'])", None)
    assert r.returncode == 0 and "torch was imported" not in r.stderr
    assert r.stdout.strip() == "PASSIVE"
    r = _run("import torch\nimport dcdc\nimport os\nprint(os.environ['OMP_WAIT_POLICY'])",
             "ACTIVE")  # a setting of the user's own is kept, and not warned about
    assert r.returncode == 0 and "torch was imported" not in r.stderr
    assert r.stdout.strip() == "ACTIVE"
