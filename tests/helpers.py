"""Shared test helpers: run the ``dcdc`` command line in-process."""
from dcdc.cli import main


def dcdc_exit(*args) -> int:
    """Exit status of ``dcdc ARGS`` (0 when it returns normally)."""
    try:
        main([str(a) for a in args])
    except SystemExit as e:
        return e.code or 0
    return 0


def dcdc_output(args, capsys) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``dcdc ARGS``."""
    code = dcdc_exit(*args)
    out = capsys.readouterr()
    return code, out.out, out.err


def dcdc(capsys, *args) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``dcdc ARGS`` (any argument turned into a string)."""
    return dcdc_output([str(a) for a in args], capsys)


TANK = """name = "{name}"
dim = 2
radius = {radius}
seed = {seed}
duration = {duration}
[domain]
min = [0.0, 0.0]
max = [1.0, 1.0]
[phases.water]
density = 1000.0
[walls.tank]
shape = "box"
min = [0.0, 0.0]
max = [1.0, 1.0]
hollow = true
[[fluid]]
phase = "water"
shape = "box"
min = [0.1, 0.1]
max = [0.5, 0.5]
"""


def tank_toml(name="tank", radius=0.025, seed=0, duration=1.0) -> str:
    """A 2-D scene file's text: a block of water in a closed 1 m box tank, with the fields given."""
    return TANK.format(name=name, radius=radius, seed=seed, duration=duration)
