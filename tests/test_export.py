import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.export import write_points


def _read_ply(path):
    raw = open(path, "rb").read()
    head, body = raw.split(b"end_header\n", 1)
    props = [l.split()[-1].decode() for l in head.splitlines() if l.startswith(b"property")]
    n = int([l for l in head.splitlines() if l.startswith(b"element vertex")][0].split()[-1])
    table = np.frombuffer(body, dtype="<f4").reshape(n, len(props))
    return props, table


@pytest.mark.parametrize("dim", [2, 3])
def test_ply_roundtrip(tmp_path, dim):
    rng = np.random.default_rng(0)
    x = rng.normal(size=(50, dim))
    v = rng.normal(size=(50, dim))
    phase = rng.integers(0, 4, 50)
    props, table = _read_ply(write_points(tmp_path / "f.ply", x, {"velocity": v, "phase": phase}))
    assert props[:3] == ["x", "y", "z"] and "velocity_x" in props and props[-1] == "phase"
    np.testing.assert_allclose(table[:, :dim], x, rtol=1e-6)
    np.testing.assert_array_equal(table[:, -1], phase)
    if dim == 2:
        assert np.all(table[:, 2] == 0)


def test_vtk_layout(tmp_path):
    x = np.arange(12, dtype=float).reshape(4, 3)
    path = write_points(tmp_path / "f.vtk", x, {"density": np.array([1.0, 2, 3, 4])})
    raw = path.read_bytes()
    i = raw.index(b"POINTS 4 float\n") + len(b"POINTS 4 float\n")
    np.testing.assert_array_equal(np.frombuffer(raw[i:i + 48], ">f4").reshape(4, 3), x)
    j = raw.index(b"LOOKUP_TABLE default\n") + len(b"LOOKUP_TABLE default\n")
    np.testing.assert_array_equal(np.frombuffer(raw[j:j + 16], ">f4"), [1, 2, 3, 4])
    assert not list(tmp_path.glob("*.part"))


def test_bad_export_input(tmp_path):
    with pytest.raises(DcdcError, match="unknown point-cloud format"):
        write_points(tmp_path / "f.xyz", np.zeros((2, 3)))
    with pytest.raises(DcdcError, match="field 'a' has 3 values for 2"):
        write_points(tmp_path / "f.ply", np.zeros((2, 3)), {"a": np.zeros(3)})
