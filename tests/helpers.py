import re
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


FORMAT2_ONLY = ("attrs_sha256", "job_key", "max_density_ratio", "removed")  # group attributes


def format1_copy(src, dst) -> None:
    """Copy the trajectory file ``src`` to ``dst`` as format 1 wrote it: no Fletcher-32
    checksums, no ``death`` array (written before particles could be removed) and none of
    the group attributes of :data:`FORMAT2_ONLY`."""
    import h5py
    with h5py.File(src) as f, h5py.File(dst, "w") as out:
        out.attrs["format"] = f.attrs["format"]
        out.attrs["format_version"] = 1
        for name, g in f.items():
            h = out.create_group(name)
            for k, arr in g.items():
                if k != "death":
                    h.create_dataset(k, data=arr[()], chunks=arr.chunks, compression=arr.compression)
            for k, v in g.attrs.items():
                if k not in FORMAT2_ONLY + ("complete",):
                    h.attrs[k] = v
            h.attrs["complete"] = 1  # last, as the writer did


def assert_error_last_line(code, err, *words):
    """A command's failure: exit 2, its last line ``error: ...`` holding ``words``, no traceback."""
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert code == 2, err
    assert lines and lines[-1].startswith("error: "), err
    assert not any("Traceback" in ln for ln in lines), err
    for w in words:
        assert w in lines[-1], (w, lines[-1])


def norm_title(s: str) -> str:
    """A doc section title as citations and headings are compared: spaces and backticks
    folded, lower case, trailing punctuation dropped."""
    return re.sub(r"[\s`]+", " ", s).strip().lower().rstrip(".:,?")


def doc_titles(md) -> list[str]:
    """Headings, and the bold or italic titles that open a paragraph, of a Markdown file."""
    out = []
    for line in md.read_text(encoding="utf-8").splitlines():
        m = re.match(r"#+\s+(.*)", line) or re.match(r"(?:\*\*|\*)([^*]+?)(?:\*\*|\*)", line)
        if m:
            out.append(norm_title(m.group(1)))
    return out
