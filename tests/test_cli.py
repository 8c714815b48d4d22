import subprocess
import sys


def run(*args):
    return subprocess.run([sys.executable, "-m", "dcdc.cli", *args], capture_output=True, text=True)


def test_help_lists_verbs():
    r = run("--help")
    assert r.returncode == 0
    assert "benchmark" in r.stdout


def test_unknown_verb_fails():
    r = run("no-such-verb")
    assert r.returncode != 0
