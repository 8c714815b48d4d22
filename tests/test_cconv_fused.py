"""The fused CConv kernels (dcdc/model/fused.py) against the unfused numba operator."""
import numba
import numpy as np
import pytest
import torch

import dcdc.model.cconv as cc
import dcdc.model.fused as fu
from dcdc.model.cconv import build_geometry, cconv, reference_cconv

R = 0.1125
pytestmark = pytest.mark.skipif(not fu.AVAILABLE, reason="torch without MKL: no fused kernels")


def _points(n, dim, seed=0, extent=0.3):
    return np.random.default_rng(seed).uniform(0, extent, (n, dim))


def _out_and_grads(F, W, geom, backend):
    F = F.detach().clone().requires_grad_()
    W = W.detach().clone().requires_grad_()
    out = cconv(F, W, geom, backend=backend)
    gF, gW = torch.autograd.grad(out.sin().sum(), (F, W))
    return out.detach(), gF, gW


def _assert_close(a, b, tol):
    scale = float(b.abs().max()) or 1.0
    torch.testing.assert_close(a, b, rtol=tol, atol=tol * scale)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
@pytest.mark.parametrize("normalize", [False, True])
@pytest.mark.parametrize("cin,cout", [(4, 16), (16, 8), (5, 3)])
def test_fused_equals_numba_outputs_and_gradients(dim, dtype, normalize, cin, cout):
    """Forward and both gradients equal the unfused operator's to 1e-5 (float32 and float64);
    (5, 3) is a spread-form forward whose backward spreads 3-channel gradients."""
    n = 400 if dim == 3 else 250
    x = _points(n, dim, seed=dim, extent=0.4)
    geom = build_geometry(x, radius=R, normalize=normalize, dtype=dtype)
    g = torch.Generator().manual_seed(cin)
    F = torch.randn(n, cin, generator=g, dtype=torch.float64).to(dtype)
    W = (0.3 * torch.randn(4 ** dim, cin, cout, generator=g, dtype=torch.float64)).to(dtype)
    assert cc._fused_applies(F, W, geom, None)
    tol = 1e-5 if dtype == torch.float32 else 1e-12
    for a, b in zip(_out_and_grads(F, W, geom, "fused"), _out_and_grads(F, W, geom, "numba")):
        _assert_close(a, b, tol)


@pytest.mark.parametrize("dim", [2, 3])
def test_fused_matches_reference_cross_geometry(dim):
    """Wall → fluid (other senders, self kept, K = 3) against the slow per-edge reference."""
    x = _points(60, dim, seed=1)
    walls = _points(50, dim, seed=2)
    F = torch.randn(50, dim, dtype=torch.float64)
    W = torch.randn(3 ** dim, dim, 6, dtype=torch.float64)
    geom = build_geometry(x, walls, radius=R, kernel_size=3)
    ref = reference_cconv(x, walls, F.numpy(), W.numpy(), R, exclude_self=False)
    np.testing.assert_allclose(cconv(F, W, geom, backend="fused").numpy(), ref, rtol=1e-7,
                               atol=1e-9)


def test_fused_gradcheck_and_virtual_senders():
    """Virtual senders (several edges reading one modulated row, as the density plan does)."""
    x = _points(30, 3, seed=4, extent=0.15)
    geom = build_geometry(x, radius=R, normalize=True)
    src = (geom.src % 7).astype(np.int32)  # 7 virtual rows shared by many edges
    vg = geom.with_sources(src, 7)
    F = torch.randn(7, 3, dtype=torch.float64, requires_grad=True)
    W = torch.randn(64, 3, 5, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda f, w: cconv(f, w, vg, backend="fused"), (F, W))
    for a, b in zip(_out_and_grads(F, W, vg, "fused"), _out_and_grads(F, W, vg, "numba")):
        _assert_close(a, b, 1e-12)


@pytest.mark.parametrize("threads", [1, 2])
def test_fused_blocks_and_threads_do_not_change_the_result(monkeypatch, threads):
    """Tiny blocks (4 rows) and 1 or 2 threads: the same numbers (to rounding of the sums)."""
    x = _points(500, 3, seed=3, extent=0.4)
    geom = build_geometry(x, radius=R, dtype=torch.float32)
    F = torch.randn(500, 8)
    W = 0.2 * torch.randn(64, 8, 8)
    ref = _out_and_grads(F, W, geom, "numba")
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        monkeypatch.setattr(fu, "BLOCK_BYTES", 1)
        res = _out_and_grads(F, W, geom, "fused")
    finally:
        numba.set_num_threads(old)
    for a, b in zip(res, ref):
        _assert_close(a, b, 1e-5)


def test_fused_forward_is_the_unfused_forward_bit_for_bit():
    """Same spread order and the same BLAS: the forward is identical, not only close."""
    x = _points(800, 3, seed=5, extent=0.5)
    geom = build_geometry(x, radius=R, dtype=torch.float32)
    F = torch.randn(800, 16)
    W = 0.1 * torch.randn(64, 16, 16)
    with torch.no_grad():
        torch.testing.assert_close(cconv(F, W, geom, backend="fused"),
                                   cconv(F, W, geom, backend="numba"), rtol=0, atol=0)


def test_fused_leaves_the_callers_blas_threads_alone():
    """The kernel asks MKL for one thread inside its parallel region and restores the setting:
    torch's own GEMMs afterwards still run with torch's thread count."""
    import ctypes
    import os
    lib = ctypes.CDLL(os.path.join(os.path.dirname(torch.__file__), "lib", "libtorch_cpu.so"))
    before = lib.mkl_get_max_threads()
    x = _points(300, 3, seed=6)
    geom = build_geometry(x, radius=R)
    F = torch.randn(300, 8, dtype=torch.float64, requires_grad=True)
    cconv(F, torch.randn(64, 8, 8, dtype=torch.float64), geom, backend="fused").sum().backward()
    assert lib.mkl_get_max_threads() == before


def test_auto_backend_is_the_fused_one_on_cpu():
    assert cc.DEFAULT_CPU_BACKEND == "fused"


@pytest.mark.parametrize("name", ["dcdc2d"])
def test_shipped_model_gives_the_same_outputs_with_the_fused_kernels(name):
    """A shipped checkpoint on a small random 2-D state: fused and unfused operators agree."""
    from dcdc.model.checkpoint import load_checkpoint

    model, _ = load_checkpoint(name)
    r = model.cfg.particle_radius if hasattr(model.cfg, "particle_radius") else 0.025
    rng = np.random.default_rng(0)
    side = 12
    g = np.arange(side) * 2 * r
    x = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    x = x + rng.uniform(-0.2 * r, 0.2 * r, x.shape)
    v = rng.normal(scale=0.3, size=x.shape)
    rho = np.where(x[:, 1] > x[:, 1].mean(), 1000.0, 2000.0)
    wx = np.stack([np.linspace(-r, side * 2 * r, 30), np.full(30, -2 * r)], 1)
    wn = np.tile([0.0, 1.0], (30, 1))
    res = {}
    for backend in ("numba", "fused"):
        model.set_backend(backend)
        with torch.no_grad():
            res[backend] = model(x, v, rho, wx, wn)
    model.set_backend("auto")
    _assert_close(res["fused"], res["numba"], 1e-5)


def test_fused_ab_benchmark_cli(tmp_path):
    """``dcdc benchmark cconv --fused-ab`` (tiny sizes; no timing asserts)."""
    import json

    from click.testing import CliRunner

    from dcdc.model.benchmark import cconv_command

    out = tmp_path / "ab.json"
    res = CliRunner().invoke(cconv_command, ["--fused-ab", "300", "--repeat", "1",
                                             "--json", str(out)])
    assert res.exit_code == 0, res.output
    rows = json.loads(out.read_text())["rows"]
    assert [r["widths"] for r in rows] == ["default", "dcdc3d"]
    assert all(r["fwd_ratio"] > 0 and r["train_ratio"] > 0 for r in rows)


def test_shipped_3d_model_is_unchanged_by_the_fused_kernels():
    """``dcdc3d`` on a small two-phase tank: the fused forward is the unfused one."""
    from dcdc.model.benchmark import tank
    from dcdc.model.checkpoint import load_checkpoint

    model, _ = load_checkpoint("dcdc3d")
    x, v, rho, wx, wn = tank(500)
    s = model.cfg.particle_radius / 0.025  # tank() is laid out for r = 2.5 cm
    res = {}
    for backend in ("numba", "fused"):
        model.set_backend(backend)
        with torch.no_grad():
            res[backend] = model(x * s, v, rho, wx * s, wn)
    model.set_backend("auto")
    _assert_close(res["fused"], res["numba"], 1e-5)
