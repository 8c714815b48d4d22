"""dcdc view: the page's data decode to the trajectory, the page is offline, and in headless
Chromium (when installed) it draws particles, playback advances at the chosen speed, the
colouring switches between phase, speed and density, and the scale bar has the picture's
scale."""
import base64
import json
import re
import shutil
import subprocess
import tempfile

import numpy as np
import pytest

from dcdc.render.figures import open_trajectory
from dcdc.render.view import page_data, render_page, view_frames
from helpers import dcdc_exit as _cli

SAMPLE = "data/sample/test2d/hourglass_2d.h5"


def test_view_frames_subsample():
    assert view_frames(51, 200) == list(range(51))
    sel = view_frames(51, 10)
    assert len(sel) <= 10 and sel[0] == 0 and sel[-1] == 50  # the last frame is kept
    assert np.all(np.diff(sel[:-1]) == sel[1])
    assert view_frames(51, 100, stride=20) == [0, 20, 40, 50]


def test_page_data_decode_to_the_trajectory():
    traj = open_trajectory(SAMPLE)
    frames = [0, 25, 50]
    d = page_data(traj, frames)
    q = np.frombuffer(base64.b64decode(d["positions"]), "<u2").reshape(3, traj.n_particles, 3)
    lo, hi = np.array(d["lo"]), np.array(d["hi"])
    x = lo + q / 65535.0 * (hi - lo)
    err = np.abs(x[:, :, :2] - traj.position[frames]).max()
    assert err <= (hi - lo).max() / 65535 * 0.51
    assert np.array_equal(np.frombuffer(base64.b64decode(d["phase"]), np.uint8), traj.phase)
    assert d["times"] == pytest.approx(list(traj.time[frames]))
    assert [p["name"] for p in d["phases"]] == [p.name for p in traj.phases]
    n = np.frombuffer(base64.b64decode(d["wall_normals"]), np.int8).reshape(-1, 3) / 127
    np.testing.assert_allclose(n[:, :2], traj.wall_n, atol=0.005)
    # speeds: uint8 of |v| in [0, speed_max], speed_max the largest of the kept frames
    speed = np.linalg.norm(traj.velocity[frames].astype(np.float64), axis=2)
    assert d["speed_max"] == pytest.approx(speed.max())
    q = np.frombuffer(base64.b64decode(d["speed"]), np.uint8).reshape(3, traj.n_particles)
    assert np.abs(q / 255 * d["speed_max"] - speed).max() <= d["speed_max"] / 510 * 1.001
    assert q.max() == 255
    # the colour map: viridis, dark purple to yellow
    assert len(d["colormap"]) == 17 and d["colormap"][0] == pytest.approx([0.267, 0.0049, 0.3294], abs=1e-3)
    assert d["colormap"][-1] == pytest.approx([0.9932, 0.9062, 0.1439], abs=1e-3)


def test_page_is_self_contained(tmp_path):
    out = tmp_path / "v.html"
    assert _cli("view", SAMPLE, "--html", out, "--max-frames", 20) == 0
    html = out.read_text()
    assert "/*DCDC_DATA*/" not in html
    assert not re.search(r"(src|href)\s*=\s*[\"']?(https?:)?//", html)  # nothing fetched
    blob = re.search(r"var DATA = (\{.*?\});\n", html).group(1)
    assert len(json.loads(blob)["times"]) <= 20
    assert _cli("view", SAMPLE, "--html", out) == 2  # exists
    assert _cli("view", SAMPLE, "--html", tmp_path / "v.txt") == 2


def test_names_cannot_end_the_script():
    traj = open_trajectory(SAMPLE)
    d = page_data(traj, [0])
    d["name"] = "</script><script>alert(1)"
    assert "</script><script>" not in render_page(d)


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _load(page, tmp_path, hash=""):
    """The page's DOM after 3 s of virtual time in headless Chromium: (body data-*, DOM)."""
    # software WebGL (SwiftShader): CI machines have no GPU, and newer Chromium wants it asked for
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
           "--enable-unsafe-swiftshader", "--no-first-run",
           "--disable-extensions", f"--user-data-dir={tempfile.mkdtemp(dir=tmp_path)}",
           "--window-size=640,720", "--virtual-time-budget=3000", "--dump-dom",
           page.as_uri() + hash]
    # a fresh profile per run (a profile still locked by the previous browser is refused),
    # and up to three runs: a loaded machine's headless GPU process can fail to start
    for attempt in range(3):
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        body = re.search(r"<body([^>]*)>", r.stdout)
        attrs = dict(re.findall(r'data-(\w+)="([^"]*)"', body.group(1))) if body else {}
        if "frame" in attrs:
            return attrs, r.stdout
    raise AssertionError(f"the page never drew: {attrs}, {r.stdout[:300]!r}, {r.stderr[-500:]!r}")


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (apt-get install chromium)")
def test_page_plays_in_headless_chromium(tmp_path):
    out = tmp_path / "v.html"
    assert _cli("view", SAMPLE, "--html", out) == 0
    attrs, dom = _load(out, tmp_path)
    assert "error" not in attrs
    assert int(attrs["painted"]) > 200   # of 4096 probes: particles and walls on the canvas
    assert int(attrs["advanced"]) >= 5   # playback advanced (frame changes, it loops)
    assert re.search(r"<title>dcdc view: hourglass_2d frame \d+ / 50</title>", dom)
    assert attrs["speed"] == "1" and attrs["color"] == "phase"
    # a quarter of real time: a quarter of the frame changes
    slow, dom = _load(out, tmp_path, "#speed=0.25")
    assert slow["speed"] == "0.25"
    assert 5 <= int(slow["advanced"]) < 0.45 * int(attrs["advanced"])
    # paused at a chosen frame, and hiding both phases leaves only the faint walls
    paused, _ = _load(out, tmp_path, "#frame=7")
    assert paused["frame"] == "7" and "advanced" not in paused
    hidden, _ = _load(out, tmp_path, "#frame=7&hide=0,1")
    assert hidden["frame"] == "7" and 0 < int(hidden["painted"]) < 0.6 * int(paused["painted"])


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (apt-get install chromium)")
def test_colouring_switches_and_scale_bar_in_headless_chromium(tmp_path):
    traj = open_trajectory(SAMPLE)
    out = tmp_path / "v.html"
    assert _cli("view", SAMPLE, "--html", out) == 0
    runs = {c: _load(out, tmp_path, f"#frame=25&color={c}") for c in ("phase", "speed", "density")}
    rgb = {}
    for c, (attrs, dom) in runs.items():
        assert attrs["color"] == c and attrs["frame"] == "25" and "error" not in attrs
        bar = re.search(r'<span id="cbar" style="display: ([a-z-]+);', dom).group(1)
        assert bar == ("none" if c == "phase" else "inline-flex")
        rgb[c] = np.array([int(v) for v in attrs["rgb"].split(",")])
    # the same particles are drawn, in other colours
    painted = [int(a["painted"]) for a, _ in runs.values()]
    assert max(painted) < 1.1 * min(painted)
    assert np.abs(rgb["phase"] - rgb["speed"]).max() > 15
    assert np.abs(rgb["phase"] - rgb["density"]).max() > 15
    assert np.abs(rgb["speed"] - rgb["density"]).max() > 15
    # the colour bars' ranges
    vmax = np.linalg.norm(traj.velocity.astype(np.float64), axis=2).max()
    cmax = re.search(r'<span id="cmax">([0-9.]+) m/s</span>', runs["speed"][1]).group(1)
    assert float(cmax) == pytest.approx(vmax, rel=2e-3)
    dens = sorted(p.density for p in traj.phases)
    assert re.search(rf'<span id="cmin">{dens[0]:g}</span>', runs["density"][1])
    assert re.search(rf'<span id="cmax">{dens[-1]:g} kg/m³</span>', runs["density"][1])
    # scale bar: a length of 1, 2 or 5 x 10^k m drawn at the picture's pixels per metre
    attrs, dom = runs["phase"]
    length, pxm = float(attrs["scale"]), float(attrs["pxm"])
    mantissa = length / 10 ** np.floor(np.log10(length))
    assert round(mantissa, 6) in (1.0, 2.0, 5.0)
    width = float(re.search(r'<div id="scalebar" style="width: ([0-9.]+)px;', dom).group(1))
    assert width == pytest.approx(length * pxm, abs=0.1)
    assert re.search(rf'<span id="scalelabel">{length:g} m</span>', dom)
    # the painted picture (walls outermost) is as wide as the walls at that scale
    x0, x1 = (int(v) for v in attrs["extent"].split(","))
    walls = np.ptp(traj.wall_x[:, 0]) * pxm
    assert abs((x1 - x0) - walls) < 25 + 2 * traj.radius * pxm   # probes 10 px apart, sprites


@pytest.mark.slow
def test_mesh_walls_are_sent_wound_towards_the_fluid(tmp_path):
    from test_export import MESH_SCENE

    from dcdc.render.benchmark import block_trajectory
    from dcdc.render.walls import wall_meshes
    traj = open_trajectory(block_trajectory(tmp_path / "m.h5", 3, 60, frames=1,
                                            attrs={"scene_toml": MESH_SCENE}))
    d = page_data(traj, [0, 1])
    v = np.frombuffer(base64.b64decode(d["mesh_positions"]), "<f4").reshape(-1, 3, 3)
    n = np.frombuffer(base64.b64decode(d["mesh_normals"]), np.int8).reshape(-1, 3, 3) / 127
    (mesh,), _ = wall_meshes(traj)
    assert len(v) == len(mesh.triangles)
    face = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert np.all(np.einsum("ij,ij->i", face, n[:, 0]) > 0)  # counter-clockwise from the fluid
    np.testing.assert_allclose(n[:, 0], mesh.fluid_normals(), atol=0.01)
    assert "mesh_positions" not in page_data(open_trajectory(SAMPLE), [0])  # 2-D: none
    if CHROMIUM:
        out = tmp_path / "m.html"
        assert _cli("view", traj.ref.file, "--html", out) == 0
        attrs, _ = _load(out, tmp_path, "#frame=1&hide=0,1")
        assert "error" not in attrs and int(attrs["painted"]) > 0
