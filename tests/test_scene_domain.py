"""Scenes without ``[domain]``: the domain is the box around every wall, fluid block and
emitter (``dcdc.scene.realize.derive_domain``); a wall without a box (terrain) is a
one-line error; open scenes combine it with ``[solver] on_escape = "remove"``. Also the
rectangular nozzle (``[[emitter]] shape = "box"``)."""
import re
from pathlib import Path

import numpy as np
import pytest

from dcdc.errors import DcdcError, SimulationDiverged
from dcdc.scene import parse
from dcdc.scene.budget import estimate
from dcdc.scene.realize import _build_walls, _wall_bounds
from helpers import dcdc_output
from test_scene_format import MINIMAL

MODELS = Path(__file__).resolve().parent / "data" / "models"
NO_DOMAIN = MINIMAL.replace("[domain]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\n", "")


def scene3d(walls: str = "", fluid: str = "", emitter: str = "", extra: str = "") -> str:
    """A 3-D scene without a domain: one phase and the given TOML sections."""
    return (f'name = "t"\ndim = 3\nduration = 0.1\n{extra}\n[phases.water]\ndensity = 1000\n\n'
            f"{walls}\n{fluid}\n{emitter}")


BLOCK = '[[fluid]]\nphase = "water"\nshape = "box"\nmin = [0.0, 0.0, 0.0]\nmax = [0.2, 0.2, 0.2]\n'


def test_domain_is_optional_and_the_tank_gives_the_same_particles():
    assert "[domain]" in MINIMAL and "[domain]" not in NO_DOMAIN
    given, derived = parse(MINIMAL).realize(), parse(NO_DOMAIN).realize()
    assert parse(NO_DOMAIN).data["domain"] is None
    assert derived.meta["scene_domain"] == given.meta["scene_domain"] == [[0.0, 0.0], [1.0, 1.0]]
    assert np.array_equal(derived.x, given.x) and np.array_equal(derived.wall_x, given.wall_x)
    assert all(np.array_equal(a, b) for a, b in zip(derived.domain, given.domain))


def test_domain_is_the_box_around_walls_fluid_and_emitters():
    text = scene3d(
        walls='[walls.ball]\nshape = "sphere"\ncenter = [1.0, 0.5, 0.0]\nradius = 0.25\n',
        fluid=BLOCK.replace("max = [0.2, 0.2, 0.2]", "max = [0.2, 0.2, 0.2]\ntop_wave = [0.05, 0.4]"),
        emitter='[[emitter]]\nphase = "water"\nposition = [0.0, 1.5, 0.0]\ndirection = [0.0, -1.0, 0.0]\n'
                'speed = 1.0\nradius = 0.1\nstop = 0.05\n')
    sc = parse(text)
    d = sc.variant()["domain"]
    # x: block 0 .. ball 1.25; y: ball 0.25 below, nozzle (points within 0.1) + r above 1.5;
    # z: nozzle disc -0.1 - r .. ball 0.25
    assert np.allclose(d["min"], [-0.125, 0.0, -0.25]) and np.allclose(d["max"], [1.25, 1.525, 0.25])
    s = sc.realize()
    assert np.allclose(s.meta["scene_domain"], [d["min"], d["max"]])
    # the 2-D variant and a smaller resolution are derived from their own shapes
    assert np.allclose(sc.variant(2)["domain"]["max"], [1.25, 1.525])
    assert np.allclose(sc.variant(3, 0.5)["domain"]["max"], [0.625, 0.775, 0.125])


WALLS = {
    "cylinder": 'shape = "cylinder"\ncenter = [0.1, 0.2, 0.3]\nradius = 0.3\nheight = 0.8\naxis = 0',
    "bowl": 'shape = "bowl"\ncenter = [0.0, 0.1, 0.0]\nradius = 0.5\nthickness = 0.1',
    "glass": 'shape = "glass"\ncenter = [0.2, 0.0, 0.0]\nfoot = 0.3\nstem = 0.2\n'
             'bowl = [[0.0, 0.0], [0.3, 0.1], [0.35, 0.5]]\nthickness = 0.06',
    "hourglass": 'shape = "hourglass"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.4\nheight = 1.4\n'
                 'neck = 0.1\nthickness = 0.08',
    "mesh": f'shape = "mesh"\nfile = "{MODELS / "SmallCube.obj"}"\nscale = [1.0, 2.0, 1.0]\n'
            'rotation_axis = [0.0, 0.0, 1.0]\nrotation_degrees = 30.0\ntranslate = [0.5, 0.5, 0.0]',
    "shell": f'shape = "mesh"\nfile = "{MODELS / "Sheet.obj"}"\nthickness = 0.1',
}


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("shape", sorted(WALLS))
def test_wall_bounds_hold_the_solid_tightly(shape, dim):
    """Every point of a wall's solid lies in its box, and (but for a shell, on one side
    of its sheet) the solid reaches each face of the box (to within the test grid)."""
    sc = parse(scene3d(walls=f"[walls.w]\n{WALLS[shape]}\n", fluid=BLOCK, extra="radius = 0.02"))
    s = sc.variant(dim)
    lo, hi = _wall_bounds("w", s["walls"]["w"], dim, 0.08, None, {}, "t")
    sdf = _build_walls(s, None, 0.08)[0].sdf
    n = 120 if dim == 2 else 40
    pad = 0.25 * (hi - lo)
    axes = [np.linspace(a, b, n) for a, b in zip(lo - pad, hi + pad)]
    cell = max(ax[1] - ax[0] for ax in axes)
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    solid = x[sdf(x) < 0]
    assert len(solid)
    assert (solid >= lo - 1e-9).all() and (solid <= hi + 1e-9).all()
    if shape == "shell":  # one side of the sheet only: its box is the sheet grown by T
        return
    assert np.allclose(solid.min(0), lo, atol=1.5 * cell) and np.allclose(solid.max(0), hi, atol=1.5 * cell)


def test_mesh_fluid_and_mesh_emitter_count_with_their_placed_meshes():
    cube = MODELS / "SmallCube.obj"
    text = scene3d(
        fluid=f'[[fluid]]\nphase = "water"\nshape = "mesh"\nfile = "{cube}"\ntranslate = [2.0, 0.0, 0.0]\n',
        emitter=f'[[emitter]]\nshape = "mesh"\nphase = "water"\nfile = "{cube}"\nscale = 2.0\n'
                'interval = 0.05\nstop = 0.1\n')
    d = parse(text).variant()["domain"]
    import trimesh
    b = trimesh.load(cube, force="mesh").bounds
    assert np.allclose(d["min"], 2 * b[0]) and np.allclose(d["max"], [2.0 + b[1][0], *(2 * b[1][1:])])


TERRAIN = scene3d(walls='[walls.ground]\nshape = "terrain"\nx = [0.0, 2.0]\nz = [0.0, 1.0]\nbase = 0.5\n',
                  fluid=BLOCK.replace("0.0, 0.0, 0.0", "0.2, 0.8, 0.2")
                  .replace("0.2, 0.2, 0.2", "0.4, 1.0, 0.4"))


def test_terrain_without_domain_is_a_one_line_error(tmp_path, capsys):
    with pytest.raises(DcdcError, match=r"walls.ground \(terrain\) has no bounding box .* give the "
                                        r"scene a \[domain\]") as e:
        parse(TERRAIN, "t.toml").realize()
    assert "\n" not in str(e.value)
    p = tmp_path / "t.toml"
    p.write_text(TERRAIN)
    code, out, err = dcdc_output(["scene", "show", p], capsys)
    assert code == 2 and err.startswith("error: t.toml: walls.ground (terrain)") and err.count("\n") == 1
    p.write_text(TERRAIN + "\n[domain]\nmin = [0.0, -0.5, 0.0]\nmax = [2.0, 1.5, 1.0]\n")
    code, out, err = dcdc_output(["scene", "show", p], capsys)
    assert code == 0 and "derived" not in out


def test_show_says_the_domain_is_derived(tmp_path, capsys):
    p = tmp_path / "t.toml"
    p.write_text(NO_DOMAIN)
    code, out, _ = dcdc_output(["scene", "show", p], capsys)
    assert code == 0 and re.search(r"domain +\[0.0, 0.0\] \.\. \[1.0, 1.0\] m \(derived", out)


def test_domain_table_is_still_checked():
    with pytest.raises(DcdcError, match=r"domain.max must exceed domain.min"):
        parse(MINIMAL.replace("max = [1.0, 1.0]\n\n[phases", "max = [0.0, 1.0]\n\n[phases"))
    with pytest.raises(DcdcError, match=r"domain must be a table"):
        parse('domain = 3\n' + NO_DOMAIN)


LEDGE = """\
name = "ledge"
dim = 2

[phases.water]
density = 1000

[walls.ledge]
shape = "box"
min = [-0.4, -0.1]
max = [0.3, 0.0]

[[fluid]]
phase = "water"
shape = "box"
min = [-0.1, 0.0]
max = [0.3, 0.1]
velocity = [1.0, 0.0]
"""


def test_open_scene_with_derived_domain_removes_escaping_fluid():
    """A ledge and no container: the fluid slides off the box around them; with
    on_escape = "remove" it is dropped, by default the run stops with one line."""
    from dcdc.sph import Simulator
    sc = parse(LEDGE + '\n[solver]\non_escape = "remove"\n')
    s = sc.realize()
    assert s.meta["scene_domain"] == [[-0.4, -0.1], [0.3, 0.1]]
    sim = Simulator(s, sc.check_solver())
    for _ in range(12):
        sim.advance(0.02)
    assert 0 < sim.system.n_removed < s.n_fluid
    sc = parse(LEDGE)
    sim = Simulator(sc.realize(), sc.check_solver())
    with pytest.raises(SimulationDiverged, match="left the domain"):
        for _ in range(12):
            sim.advance(0.02)


# ------------------------------------------------------------------ box nozzles
BOX_NOZZLE = ('[[emitter]]\nphase = "water"\nshape = "box"\nposition = [0.5, 0.5, 0.5]\n'
              'direction = [0.0, -1.0, 0.0]\nspeed = 1.0\nwidth = 0.2\nheight = 0.1\n'
              'start = 0.0\nstop = 0.1\n')


def test_box_nozzle_is_a_width_by_height_grid():
    """A vertical jet: height along x (the default for vertical jets), width along z;
    floor(side / 2r) points per side, centred; the 2-D cross-section is the height segment."""
    sc = parse(scene3d(fluid=BLOCK, emitter=BOX_NOZZLE))
    s = sc.realize()
    layer = s.x[s.birth == s.birth.max()]
    assert len(layer) == 4 * 2
    assert np.allclose(layer.mean(0), [0.5, 0.5, 0.5]) and np.allclose(np.ptp(layer, 0), [0.05, 0, 0.15])
    assert np.allclose(s.v[s.birth > 0], [0, -1, 0])
    n_layers = len(np.unique(s.birth[s.birth > 0])) + 1
    assert (s.birth > 0).sum() + 8 == 8 * n_layers
    assert estimate(sc.variant())["emitted"] == 8 * n_layers  # the budget counts the same
    # turned: height along up = z, width along direction x up = x
    s = parse(scene3d(fluid=BLOCK, emitter=BOX_NOZZLE + "up = [0.0, 0.0, 1.0]\n")).realize()
    assert np.allclose(np.ptp(s.x[s.birth == s.birth.max()], 0), [0.15, 0, 0.05])
    s2 = sc.realize(dim=2)
    assert np.allclose(np.sort(s2.x[s2.birth == s2.birth.max(), 0]), [0.475, 0.525])


def test_box_nozzle_in_a_2d_scene():
    text = NO_DOMAIN + ('\n[[emitter]]\nphase = "oil"\nshape = "box"\nposition = [0.5, 0.8]\n'
                        'direction = [1.0, 0.0]\nspeed = 1.0\nheight = 0.15\nstop = 0.05\n')
    s = parse(text).realize()
    born = s.x[s.phase == 1][-3:]
    assert np.allclose(born[:, 0], 0.5) and np.allclose(np.sort(born[:, 1]), [0.75, 0.8, 0.85])


@pytest.mark.parametrize("edit, msg", [
    (("width = 0.2\n", ""), r"emitter\[0\].width is required \(a 3-D box nozzle is width x height\)"),
    (("height = 0.1\n", ""), r"emitter\[0\].height is required"),
    (("height = 0.1\n", "height = 0.1\nup = [0.0, 2.0, 0.0]\n"), r"emitter\[0\].up must be a vector not "
                                                                 r"along the direction"),
    (("height = 0.1\n", "height = 0.1\nradius = 0.1\n"), r"emitter\[0\].radius is not a known key"),
    (("width = 0.2\n", "width = -0.2\n"), r"emitter\[0\].width must be > 0"),
])
def test_box_nozzle_validation(edit, msg):
    with pytest.raises(DcdcError, match=msg) as e:
        parse(scene3d(fluid=BLOCK, emitter=BOX_NOZZLE.replace(*edit)), "t.toml")
    assert "\n" not in str(e.value)


def test_box_nozzle_width_and_up_are_3d_only():
    base = NO_DOMAIN + ('\n[[emitter]]\nphase = "oil"\nshape = "box"\nposition = [0.5, 0.8]\n'
                        'direction = [1.0, 0.0]\nspeed = 1.0\nheight = 0.15\nstop = 0.05\n')
    for extra in ("width = 0.1\n", "up = [0.0, 1.0]\n"):
        with pytest.raises(DcdcError, match=r"applies to 3-D scenes \(a 2-D box nozzle is a segment"):
            parse(base + extra)
