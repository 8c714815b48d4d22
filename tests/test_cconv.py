"""The CConv operator: reference equality, gradients, invariances, backends, chunking."""
import numpy as np
import pytest
import torch

import dcdc.model.cconv as cc
from dcdc.errors import DcdcError
from dcdc.model.cconv import build_geometry, cconv, reference_cconv

R = 0.1125


def _points(n, dim, seed=0, extent=0.3):
    return np.random.default_rng(seed).uniform(0, extent, (n, dim))


def _weights(dim, cin, cout, seed=0, K=4):
    g = torch.Generator().manual_seed(seed)
    return torch.randn(K ** dim, cin, cout, generator=g, dtype=torch.float64)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("normalize", [False, True])
@pytest.mark.parametrize("cin,cout", [(3, 5), (6, 2)])  # spread-first and collect-first
@pytest.mark.parametrize("backend", ["numba", "torch"])
def test_matches_reference(dim, normalize, cin, cout, backend):
    x = _points(70, dim, seed=dim)
    F = torch.randn(70, cin, dtype=torch.float64)
    W = _weights(dim, cin, cout)
    geom = build_geometry(x, radius=R, normalize=normalize)
    assert geom.n_edges > 3 * len(x)
    ref = reference_cconv(x, x, F.numpy(), W.numpy(), R, exclude_self=True, normalize=normalize)
    out = cconv(F, W, geom, backend=backend).numpy()
    np.testing.assert_allclose(out, ref, rtol=1e-5, atol=1e-5 * np.abs(ref).max())


@pytest.mark.parametrize("dim", [2, 3])
def test_cross_geometry_matches_reference(dim):
    """Wall→fluid: other senders, self not excluded, kernel size 3."""
    x = _points(50, dim, seed=1)
    walls = _points(40, dim, seed=2)
    F = torch.randn(40, dim, dtype=torch.float64)
    W = _weights(dim, dim, 4, K=3)
    geom = build_geometry(x, walls, radius=R, kernel_size=3)
    ref = reference_cconv(x, walls, F.numpy(), W.numpy(), R, exclude_self=False)
    np.testing.assert_allclose(cconv(F, W, geom).numpy(), ref, rtol=1e-5, atol=1e-9)


def test_chunked_rows_equal_unchunked(monkeypatch):
    x = _points(300, 3, seed=3, extent=0.4)
    geom = build_geometry(x, radius=R)
    F = torch.randn(300, 8, dtype=torch.float64, requires_grad=True)
    W = _weights(3, 8, 8).requires_grad_()
    out = cconv(F, W, geom)
    gF, gW = torch.autograd.grad(out.square().sum(), (F, W))
    monkeypatch.setattr(cc, "CHUNK_BYTES", 1)  # 32 rows per chunk
    out2 = cconv(F, W, geom)
    gF2, gW2 = torch.autograd.grad(out2.square().sum(), (F, W))
    for a, b in ((out, out2), (gF, gF2), (gW, gW2)):
        torch.testing.assert_close(a, b, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("backend", ["numba", "torch"])
@pytest.mark.parametrize("dim,cin,cout", [(2, 3, 4), (3, 4, 2)])
def test_gradcheck(backend, dim, cin, cout):
    x = _points(25, dim, seed=4, extent=0.15)
    geom = build_geometry(x, radius=R, normalize=True)
    F = torch.randn(25, cin, dtype=torch.float64, requires_grad=True)
    W = _weights(dim, cin, cout).requires_grad_()
    assert torch.autograd.gradcheck(lambda f, w: cconv(f, w, geom, backend=backend), (F, W))


def test_gradcheck_injective_sources():
    """Per-edge rows (the general density path) use the receiver-side backward."""
    x = _points(20, 3, seed=5, extent=0.15)
    geom = build_geometry(x, radius=R)
    eg = geom.with_sources(np.arange(geom.n_edges), geom.n_edges, injective=True)
    rows = torch.randn(geom.n_edges, 3, dtype=torch.float64, requires_grad=True)
    W = _weights(3, 3, 4).requires_grad_()
    assert torch.autograd.gradcheck(lambda f, w: cconv(f, w, eg), (rows, W))
    # per-edge rows equal to the sender rows give the plain convolution
    F = torch.randn(20, 3, dtype=torch.float64)
    torch.testing.assert_close(cconv(F[torch.from_numpy(geom.sender.astype(np.int64))], W, eg),
                               cconv(F, W, geom))


def test_translation_and_permutation_invariance():
    x = _points(200, 3, seed=6, extent=0.35)
    F = torch.randn(200, 5, dtype=torch.float64)
    W = _weights(3, 5, 7)
    out = cconv(F, W, build_geometry(x, radius=R))
    shifted = cconv(F, W, build_geometry(x + np.array([3.7, -1.25, 0.5]), radius=R))
    torch.testing.assert_close(shifted, out, rtol=1e-9, atol=1e-9)
    perm = np.random.default_rng(0).permutation(200)
    out_p = cconv(F[perm], W, build_geometry(x[perm], radius=R))
    torch.testing.assert_close(out_p, out[perm], rtol=1e-12, atol=1e-12)


def test_backends_agree_float32_and_bf16_close():
    x = _points(2000, 3, seed=7, extent=0.6)
    geom = build_geometry(x, radius=R)
    F = torch.randn(2000, 16)
    W = _weights(3, 16, 16).float() * 0.1
    a = cconv(F, W, geom, backend="numba")
    b = cconv(F, W, geom, backend="torch")
    torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-4)
    with torch.no_grad():
        c = cconv(F, W, geom, gemm_dtype=torch.bfloat16)
    assert (c - a).norm() / a.norm() < 2e-2


def test_bf16_gemm_emulation_is_torchs_bf16_gemm(monkeypatch):
    """Without bf16 instructions the bf16 GEMM is a float32 GEMM of the bf16 operands,
    rounded to bf16: torch's own bf16 GEMM to within one bf16 step (summation order)."""
    import dcdc.model.cconv as cc

    g = torch.Generator().manual_seed(3)
    a = torch.randn(64, 300, generator=g).to(torch.bfloat16)
    b = torch.randn(300, 24, generator=g).to(torch.bfloat16)
    ref = torch.mm(a, b).float()
    monkeypatch.setattr(cc, "BF16_NATIVE", False)
    emu = cc.bf16_mm(a, b)
    assert emu.dtype == torch.bfloat16
    ulp = ref.abs() * 2.0 ** -7  # one bf16 step at the result's size
    assert ((emu.float() - ref).abs() <= ulp + 1e-6).all()
    exact = a.double() @ b.double()  # and it is the rounded exact product
    assert ((emu.double() - exact).abs() <= exact.abs() * 2.0 ** -8 + 1e-5).all()
    out = torch.empty(64, 24, dtype=torch.bfloat16)
    assert cc.bf16_mm(a, b, out=out) is out and torch.equal(out, emu)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("normalize", [False, True])
def test_float32_geometry_is_the_rounded_float64_geometry(dim, normalize):
    """``build_geometry(dtype=float32)`` (what a float32 network builds) stores the
    float64 weights rounded, so the layers see exactly what ``weights_as(float32)`` gave."""
    x = _points(300, dim, seed=3)
    w = _points(40, dim, seed=4)
    for send in (None, w):
        g64 = build_geometry(x, send, radius=R, normalize=normalize)
        g32 = build_geometry(x, send, radius=R, normalize=normalize, dtype=torch.float32)
        assert g32.weights.dtype == np.float32 and g64.weights.dtype == np.float64
        np.testing.assert_array_equal(g32.cells, g64.cells)
        np.testing.assert_array_equal(g32.weights, g64.weights_as(torch.float32))
        assert g32.weights_as(torch.float32) is g32.weights  # no conversion pass


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("cout", [2, 3, 5])  # d channels (register sums) and the general loop
@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_collect_output_layer_equals_reference(dim, cout, dtype):
    """The collect form (C_out ≪ C_in, the output layer) against the slow reference, with the
    float32 geometry for a float32 layer; gradients equal the torch backend's."""
    x = _points(120, dim, seed=dim + 5)
    F = torch.randn(120, 24, dtype=torch.float64)
    W = _weights(dim, 24, cout) * 0.1
    ref = torch.as_tensor(reference_cconv(x, x, F, W, R))
    geom = build_geometry(x, radius=R, dtype=dtype)
    Ft = F.to(dtype).requires_grad_()
    Wt = W.to(dtype).requires_grad_()
    out = cconv(Ft, Wt, geom)
    tol = 1e-5 if dtype == torch.float32 else 1e-12
    torch.testing.assert_close(out.double(), ref, rtol=0, atol=tol * float(ref.abs().max()))
    out.sin().sum().backward()
    Fr, Wr = F.to(dtype).requires_grad_(), W.to(dtype).requires_grad_()
    cconv(Fr, Wr, geom, backend="torch").sin().sum().backward()
    for a, b in ((Ft.grad, Fr.grad), (Wt.grad, Wr.grad)):
        torch.testing.assert_close(a, b, rtol=0, atol=tol * float(b.abs().max()))


def test_chunk_buffers_are_reused_across_calls():
    """No fresh 8 MiB chunk buffer per layer call: the pool hands back the same memory."""
    x = _points(200, 3, seed=9)
    geom = build_geometry(x, radius=R, dtype=torch.float32)
    F = torch.randn(200, 8)
    W = _weights(3, 8, 8).float()
    a = cconv(F, W, geom)
    ptr = cc._buffer(1, 1, torch.float32).data_ptr()
    b = cconv(F, W, geom)
    assert cc._buffer(1, 1, torch.float32).data_ptr() == ptr
    torch.testing.assert_close(a, b, rtol=0, atol=0)


def test_ball_to_cube_mapping_properties():
    """Λ maps the ball into the cube, is odd, and preserves volume (uniform → uniform)."""
    rng = np.random.default_rng(8)
    p = rng.normal(size=(40000, 3))
    p *= (rng.uniform(size=(40000, 1)) ** (1 / 3)) / np.linalg.norm(p, axis=1, keepdims=True)
    u = np.array([cc._ball_to_cube3(*q) for q in p[:4000]])
    assert np.abs(u).max() <= 1 + 1e-12
    um = np.array([cc._ball_to_cube3(*(-q)) for q in p[:4000]])
    np.testing.assert_allclose(um, -u, atol=1e-14)
    # volume preservation: uniform samples of the ball land uniformly in the 8 octant-cubes
    # of the cube subdivided 4x4x4 (64 cells, ~625 samples each)
    u = np.array([cc._ball_to_cube3(*q) for q in p])
    cells = np.clip(((u + 1) / 2 * 4).astype(int), 0, 3)
    counts = np.bincount(cells[:, 0] + 4 * cells[:, 1] + 16 * cells[:, 2], minlength=64)
    assert counts.min() > 0.8 * counts.mean() and counts.max() < 1.2 * counts.mean()


def test_errors_are_one_line():
    x = _points(10, 3)
    geom = build_geometry(x, radius=R)
    with pytest.raises(DcdcError, match="feature rows"):
        cconv(torch.zeros(9, 2), torch.zeros(64, 2, 3), geom)
    with pytest.raises(DcdcError, match="filter"):
        cconv(torch.zeros(10, 2), torch.zeros(27, 2, 3), geom)
    with pytest.raises(DcdcError, match="backend"):
        cconv(torch.zeros(10, 2), torch.zeros(64, 2, 3), geom, backend="cuda-magic")
    with pytest.raises(DcdcError):
        build_geometry(np.zeros((5, 4)), radius=R)


def _open3d():
    try:
        import open3d.ml.torch as ml3d  # noqa: F401
        return ml3d
    except Exception:  # not installed (optional oracle, never a dependency)
        return None


@pytest.mark.skipif(_open3d() is None, reason="open3d.ml.torch not installed (optional oracle)")
@pytest.mark.parametrize("window", [False, True])
def test_matches_open3d_continuous_conv(window):
    """Same layout (x-fastest cells, sender − receiver), mapping and interpolation as open3d."""
    ml3d = _open3d()
    x = _points(300, 3, seed=9, extent=0.4).astype(np.float32)
    F = torch.randn(300, 4, requires_grad=True)
    W = _weights(3, 4, 6).float()

    def poly6(r_sqr):
        return torch.clamp((1 - r_sqr) ** 3, 0, 1)

    layer = ml3d.layers.ContinuousConv(kernel_size=[4, 4, 4], activation=None, use_bias=False,
                                       align_corners=True, interpolation="linear",
                                       coordinate_mapping="ball_to_cube_volume_preserving",
                                       normalize=False, window_function=poly6 if window else None,
                                       radius_search_ignore_query_points=True,
                                       in_channels=4, filters=6)
    layer.kernel.data = W.reshape(4, 4, 4, 4, 6).clone()  # [z, y, x, Cin, Cout]
    xt = torch.from_numpy(x)
    ref = layer(F, xt, xt, extents=2 * R)
    (gref,) = torch.autograd.grad(ref.square().sum(), F)
    out = cconv(F, W, build_geometry(x, radius=R, window=window))
    (gout,) = torch.autograd.grad(out.square().sum(), F)
    torch.testing.assert_close(out, ref, rtol=1e-4, atol=1e-4)
    torch.testing.assert_close(gout, gref, rtol=1e-4, atol=1e-3)
