"""dcdc render: camera, sphere splatting, frames, labels, outputs and the command line."""
import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.render.benchmark import block_trajectory
from dcdc.render.camera import fit_camera
from dcdc.render.compare import mean_nearest_distance, nearest_distance
from dcdc.render.figures import Figure, open_trajectory, select_frames, strip_frames
from dcdc.render.frames import BACKGROUND, FrameRenderer, default_camera
from dcdc.render.splat import splat
from helpers import dcdc_exit as cli

SAMPLE = "data/sample/test2d"


@pytest.fixture(scope="module")
def traj2d():
    return open_trajectory(SAMPLE, "hourglass_2d")


@pytest.fixture(scope="module")
def traj3d(tmp_path_factory):
    path = block_trajectory(tmp_path_factory.mktemp("b") / "block.h5", 3, 500, frames=6)
    return open_trajectory(path)


def corners(lo, hi):
    return np.array([[a, b, c] for a in (lo[0], hi[0]) for b in (lo[1], hi[1]) for c in (lo[2], hi[2])])


@pytest.mark.parametrize("az,el", [(-35, 25), (0, 0), (90, 60), (180, -30)])
def test_3d_camera_fits_the_box_tightly(az, el):
    lo, hi = np.array([0.0, 0, 0]), np.array([2.0, 1, 0.5])
    cam = fit_camera(lo, hi, 400, 300, azimuth=az, elevation=el)
    sx, sy, depth, ppm = cam.project(corners(lo, hi))
    assert np.all(depth > 0)
    assert sx.min() >= 0 and sx.max() <= 400 and sy.min() >= 0 and sy.max() <= 300
    # tight: the box touches (within the margin) the left/right or top/bottom border
    assert min(sx.min(), 400 - sx.max(), sy.min(), 300 - sy.max()) < 0.05 * 300
    # a point at the centre lands in the middle, scale = focal / distance there
    cx, cy, d, p = cam.project(((lo + hi) / 2)[None])
    assert abs(cx[0] - 200) < 1e-6 and abs(cy[0] - 150) < 1e-6
    assert p[0] == pytest.approx(cam.pixels_per_metre_at_target())


def test_2d_camera_is_orthographic_y_up():
    cam = fit_camera([0.0, 0.0], [1.0, 2.0], 200)
    assert cam.height == 400
    sx, sy, _, ppm = cam.project(np.array([[0.0, 0.0], [1.0, 2.0]]))
    assert sx[0] < sx[1] and sy[0] > sy[1]  # y up on screen
    assert ppm[0] == ppm[1] == pytest.approx(cam.scale)
    with pytest.raises(DcdcError, match="3-D trajectories only"):
        fit_camera([0.0, 0.0], [1.0, 2.0], 200, azimuth=10)


def test_splat_nearest_sphere_wins_and_shading_follows_the_light():
    zbuf = np.full((40, 40), np.inf)
    ids = np.full((40, 40), -1, np.int32)
    # sphere 0 behind sphere 1, both centred on the same pixel
    sx, sy, rad, order = splat([20.0, 20.0], [20.0, 20.0], [5.0, 3.0], [10.0, 6.0], 0.1, zbuf, ids)
    near = np.where(order == 1)[0][0]
    assert ids[20, 20] == near          # the nearer (smaller) sphere is in front
    assert ids[20, 28] == np.where(order == 0)[0][0]  # outside it the far one shows
    assert ids[20, 35] == -1 and ids[0, 0] == -1       # outside both: nothing
    assert zbuf[20, 20] == pytest.approx(3.0 - 0.1, abs=1e-3)
    # shading: lit from the upper left, in the sphere's own colour
    from dcdc.render.splat import LIGHT, MATERIAL, shade_layer
    rgb = np.zeros((40, 40, 3))
    colors = np.array([[0.2, 0.4, 0.8], [0.2, 0.4, 0.8]])
    shade_layer(ids, sx, sy, rad, colors, LIGHT, MATERIAL, rgb)
    upper_left, lower_right = rgb[16, 16], rgb[24, 24]
    assert upper_left.sum() > 1.5 * lower_right.sum()
    assert lower_right[2] / lower_right[0] == pytest.approx(4.0)  # no highlight there: pure colour
    assert np.all(rgb[0, 0] == 0)


def test_parallel_bands_draw_the_same_picture():
    rng = np.random.default_rng(1)
    n = 300
    args = (rng.uniform(0, 64, n), rng.uniform(0, 48, n), rng.uniform(1, 2, n),
            rng.uniform(1, 6, n), 0.05)
    out = []
    for bands in (1, 3, 7):
        zbuf, ids = np.full((48, 64), np.inf), np.full((48, 64), -1, np.int32)
        splat(*args, zbuf, ids, bands=bands)
        out.append((zbuf, ids))
    for zbuf, ids in out[1:]:
        np.testing.assert_array_equal(zbuf, out[0][0])
        np.testing.assert_array_equal(ids, out[0][1])
    assert (out[0][1] >= 0).mean() > 0.5


def test_2d_frame_shows_each_particle_in_its_phase_colour(traj2d):
    cam = default_camera(traj2d, 300)
    r = FrameRenderer(traj2d, cam, supersample=1)
    img = r.draw(10).astype(float) / 255
    x, _ = r.fluid(10)
    sx, sy, _, _ = cam.project(x)
    pix = img[sy.astype(int), sx.astype(int)]
    colors = np.array([p.color for p in traj2d.phases])
    # the lit centre of a sphere is the phase colour times ambient + diffuse light
    nearest = np.argmin(((pix[:, None, :] / pix.max(1, keepdims=True)[:, None]
                          - colors[None] / colors.max(1, keepdims=True)[None]) ** 2).sum(-1), 1)
    assert np.mean(nearest == traj2d.phase) > 0.97
    # empty corners are background
    assert np.allclose(img[0, 0], BACKGROUND, atol=2 / 255)


def test_3d_cut_away_removes_the_front(traj3d):
    lo_z = traj3d.position[0][:, 2].min()
    cam = default_camera(traj3d, 200)
    full = FrameRenderer(traj3d, cam, supersample=1)
    fig = Figure.build([traj3d], cam, "z=%g" % (lo_z + 0.1), 1)
    x, _ = fig.renderers[0].fluid(2)
    assert len(x) < len(full.fluid(2)[0]) and x[:, 2].max() <= lo_z + 0.1
    # fewer particles drawn: the picture changes
    assert np.any(fig.renderers[0].draw(2) != full.draw(2))
    with pytest.raises(DcdcError, match="expected x, y or z"):
        Figure.build([traj3d], cam, "w=1")


def test_walls_facing_away_are_cut_away(traj3d):
    cam = default_camera(traj3d, 200, azimuth=0, elevation=0)  # looking along -z
    keep = cam.faces_camera(traj3d.wall_x, traj3d.wall_n)
    n = traj3d.wall_n
    assert not keep[n[:, 2] < -0.5].any()   # front wall (normal away from the eye): hidden
    assert keep[n[:, 2] > 0.5].all()        # back wall: shown


@pytest.mark.parametrize("dim", [2, 3])
def test_nearest_distance_matches_brute_force(dim):
    rng = np.random.default_rng(dim)
    a = rng.uniform(0, 1, (300, dim))
    b = rng.uniform(-0.3, 1.4, (200, dim))
    brute = np.sqrt(((a[:, None] - b[None]) ** 2).sum(-1)).min(1)
    np.testing.assert_allclose(nearest_distance(a, b, 0.05), brute, rtol=1e-12)
    assert mean_nearest_distance(a, a, 0.05) == 0.0
    # a rigid shift by s much smaller than the spacing moves every particle by s
    g = np.stack(np.meshgrid(*[np.arange(8) * 0.1] * dim, indexing="ij"), -1).reshape(-1, dim)
    shift = np.zeros(dim)
    shift[0] = 0.01
    assert mean_nearest_distance(g, g + shift, 0.05) == pytest.approx(0.01)


def test_frame_and_time_selection(traj2d):
    assert select_frames(traj2d, "0:10", 3) == [0, 3, 6, 9]
    assert select_frames(traj2d, "-2:") == [49, 50]
    assert select_frames(traj2d, "7") == [7]
    assert strip_frames(traj2d, "0,0.5,1.0") == [0, 25, 50]
    with pytest.raises(DcdcError, match="outside"):
        strip_frames(traj2d, "0,5")
    with pytest.raises(DcdcError, match="selects no frame"):
        select_frames(traj2d, "60:70")
    with pytest.raises(DcdcError, match="expected A:B"):
        select_frames(traj2d, "a:b")


def test_render_strip_and_compare_cli(tmp_path, traj2d, capsys):
    from PIL import Image
    out = tmp_path / "strip.png"
    assert cli("render", SAMPLE, "-t", "hourglass_2d", "--strip", "0,0.5,1", "--width", 120,
               "--out", out) == 0
    one = np.asarray(Image.open(out))
    assert one.shape[1] >= 3 * 120  # three panels side by side
    cmp = tmp_path / "cmp.png"
    h5 = f"{SAMPLE}/hourglass_2d.h5"
    assert cli("render", "--compare", h5, h5, "--strip", "0,1", "--width", 120, "--out", cmp) == 0
    two = np.asarray(Image.open(cmp))
    assert two.shape[0] > 1.8 * (one.shape[0] - 60)  # two rows
    cam = default_camera(traj2d, 100)
    assert Figure.build([traj2d, traj2d], cam).error_mm(20) == 0.0


def test_render_animation_outputs(tmp_path, traj3d):
    import imageio.v3 as iio
    path = traj3d.ref.file
    gif = tmp_path / "a.gif"
    assert cli("render", path, "--frames", "0:6", "--stride", 2, "--width", 96, "--out", gif,
               "--no-progress") == 0
    assert iio.imread(gif, index=None).shape[0] == 3
    mp4 = tmp_path / "a.mp4"
    assert cli("render", path, "--width", 96, "--out", mp4, "--no-progress", "--azimuth", 30) == 0
    assert sum(1 for _ in iio.imiter(mp4, plugin="FFMPEG")) == traj3d.n_frames
    folder = tmp_path / "frames"
    assert cli("render", path, "--frames", "1:3", "--width", 64, "--out", folder, "--no-progress") == 0
    assert sorted(p.name for p in folder.iterdir()) == ["frame_00000.png", "frame_00001.png"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporaries left


def test_render_refuses_bad_requests(tmp_path, capsys):
    out = tmp_path / "x.png"
    out.write_bytes(b"old")
    h5 = f"{SAMPLE}/hourglass_2d.h5"
    cases = [
        (("render", h5, "--strip", "0", "--out", out), "exists (use --overwrite"),
        (("render", SAMPLE, "--strip", "0", "--out", tmp_path / "y.png"), "choose one with --trajectory"),
        (("render", SAMPLE, "-t", "nope", "--strip", "0", "--out", tmp_path / "y.png"), "no trajectory 'nope'"),
        (("render", tmp_path / "missing.h5", "--out", tmp_path / "y.gif"), "no such"),
        (("render", h5, "--out", tmp_path / "y.avi"), "unknown output type"),
        (("render", h5, "--strip", "0", "--out", tmp_path / "y.gif"), "name the output .png"),
        (("render", h5, "--out", tmp_path / "y.png"), "holds one picture"),
        (("render", h5, "--azimuth", 10, "--out", tmp_path / "y.gif"), "3-D trajectories only"),
        (("render", "--out", tmp_path / "y.gif"), "either TRAJ or --compare"),
    ]
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not hdf5 at all")
    cases.append((("render", bad, "--out", tmp_path / "y.gif"), "not a readable HDF5 file"))
    keep = tmp_path / "keep"
    keep.mkdir()
    (keep / "notes.txt").write_text("mine")
    cases.append((("render", h5, "--out", keep, "--overwrite"), "holds other things"))
    for args, msg in cases:
        assert cli(*args) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("error: ") and msg in err[0], (args, err)
    assert out.read_bytes() == b"old" and (keep / "notes.txt").exists()


def test_nan_positions_of_a_diverged_rollout_are_skipped(tmp_path, traj3d):
    import shutil

    import h5py
    path = tmp_path / "nan.h5"
    shutil.copy(traj3d.ref.file, path)
    with h5py.File(path, "r+") as f:
        f[traj3d.name]["position"][2, :5] = np.nan
    bad = open_trajectory(path)
    cam = default_camera(bad, 120)
    fig = Figure.build([traj3d, bad], cam, None, 1)
    assert len(fig.renderers[1].present(2)) == traj3d.n_particles - 5
    assert fig.renderers[1].draw(2).shape == (cam.height, cam.width, 3)
    assert 0 < fig.error_mm(2) < 1.0 and fig.error_mm(1) == 0.0


def test_titles_shrink_then_shorten_to_fit():
    from dcdc.render.overlay import fit_text, font
    from PIL import Image, ImageDraw
    d = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    assert fit_text("short", 500, 14) == ("short", 14)
    text, fs = fit_text("a rather long title for a narrow panel", 120, 14)
    assert d.textlength(text, font=font(fs)) <= 120 and fs >= 9
    text, fs = fit_text("a rather long title for a narrow panel of forty pixels", 40, 14)
    assert "…" in text and fs == 9 and d.textlength(text, font=font(fs)) <= 40


@pytest.mark.parametrize("name", ["a.mp4", "a.gif", "frames"])
def test_failed_render_leaves_nothing(tmp_path, traj3d, monkeypatch, name):
    calls = []

    def failing(self, f):
        calls.append(f)
        if len(calls) == 2:
            raise DcdcError("stop here")
        return np.full((64, 64, 3), 200, np.uint8)

    monkeypatch.setattr(Figure, "frame", failing)
    assert cli("render", traj3d.ref.file, "--width", 64, "--out", tmp_path / name, "--no-progress") == 2
    assert list(tmp_path.iterdir()) == []  # neither the output nor a temporary


@pytest.mark.slow
def test_triangles_cover_their_area_with_perspective_correct_depth():
    from dcdc.render.splat import splat_triangles
    zbuf = np.full((64, 64), np.inf)
    rgb = np.zeros((64, 64, 3))
    px, py = np.array([10.0, 50.0, 10.0, 5.0]), np.array([10.0, 10.0, 50.0, 5.0])
    pz = np.array([1.0, 1.0, 3.0, -1.0])
    tris = np.array([[0, 1, 2], [0, 1, 3]])  # the second reaches behind the camera
    splat_triangles(px, py, pz, tris, np.array([0.5, 0.5]), np.array([1.0, 0.8, 0.6]),
                    zbuf, rgb, 0.0)
    covered = np.isfinite(zbuf)
    assert abs(covered.sum() - 800) < 45           # area 40 * 40 / 2, up to the edge pixels
    assert not covered[:9].any()                    # nothing from the skipped triangle
    # at the centroid 1/z is the mean of the vertices' 1/z (not z itself)
    cy, cx = 23, 23  # pixel centre (23.5, 23.5) is near the centroid (23.3, 23.3)
    wa, wb = 1 - (23.5 - 10) / 40 * 2, (23.5 - 10) / 40
    want = 1 / (wa * 1 + wb * 1 + (1 - wa - wb) / 3)
    assert zbuf[cy, cx] == pytest.approx(want, rel=1e-9)
    np.testing.assert_allclose(rgb[cy, cx], [0.5, 0.4, 0.3])


def test_mesh_walls_are_drawn_as_surfaces(tmp_path):
    from test_export import MESH_SCENE
    plain = open_trajectory(block_trajectory(tmp_path / "p.h5", 3, 60, frames=1))
    meshy = open_trajectory(block_trajectory(tmp_path / "m.h5", 3, 60, frames=1,
                                             attrs={"scene_toml": MESH_SCENE}))
    cam = default_camera(plain, 160)
    a, b = (FrameRenderer(t, cam, supersample=1) for t in (plain, meshy))
    assert [m.name for m in b.meshes] == ["rock"] and not a.meshes
    assert np.isfinite(b._walls[0]).sum() > np.isfinite(a._walls[0]).sum()
    assert np.any(a.draw(0) != b.draw(0))
    assert not FrameRenderer(meshy, cam, walls=False).meshes
