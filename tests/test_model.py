"""Density modulation, networks, integrator and checkpoints."""
import argparse

import numpy as np
import pytest
import torch

from dcdc.errors import DcdcError
from dcdc.model.cconv import build_geometry, reference_cconv
from dcdc.model.checkpoint import FORMAT, digest, load_checkpoint, save_checkpoint
from dcdc.model.integrator import inertial, rollout, step
from dcdc.model.layers import CConvLayer, DensityCConvLayer
from dcdc.model.modulation import DensityEmbedding, DensityPlan
from dcdc.model.networks import NETWORKS, CorrectionNet, build_network

R = 0.1125
SMALL = dict(channels=[8, 12, 12])


def _block(dim, n_side=6, seed=0, jitter=0.005):
    rng = np.random.default_rng(seed)
    g = np.arange(n_side) * 0.05
    x = np.stack(np.meshgrid(*[g] * dim, indexing="ij"), -1).reshape(-1, dim)
    return x + rng.uniform(-jitter, jitter, x.shape)


def _scene(dim, n_side=6, seed=0):
    x = _block(dim, n_side, seed)
    rng = np.random.default_rng(seed + 1)
    v = rng.normal(size=x.shape)
    rho = np.where(x[:, 1] > x[:, 1].mean(), 500.0, 2000.0)
    rho[::7] = 1000.0
    m = 40
    wx = rng.uniform(0, 0.05 * n_side, (m, dim))
    wx[:, 1] = -0.05
    wn = np.zeros((m, dim))
    wn[:, 1] = 1.0
    return x, v, rho, wx, wn


def _net(name, dim, **kw):
    torch.manual_seed(0)
    return build_network(name, dim, **{**SMALL, **kw}).double()


def _perturb_modulation(net):
    """Random modulation weights, so γ, β are far from constant."""
    g = torch.Generator().manual_seed(1)
    with torch.no_grad():
        for n, p in net.named_parameters():
            if "modulation" in n or "embedding" in n:
                p.copy_(torch.randn(p.shape, generator=g, dtype=p.dtype))
    return net


# ---------------------------------------------------------------------- modulation
@pytest.mark.parametrize("dim", [2, 3])
def test_modulated_layer_matches_reference(dim):
    x, _, rho, _, _ = _scene(dim, 4 if dim == 3 else 7)
    n = len(x)
    torch.manual_seed(0)
    layer = DensityCConvLayer(3, 4, dim).double()
    emb = DensityEmbedding().double()
    _perturb_modulation(torch.nn.ModuleDict({"modulation": layer.modulation, "embedding": emb}))
    F = torch.randn(n, 3, dtype=torch.float64)
    geom = build_geometry(x, radius=R)
    rho_t = torch.tensor(rho)
    e = emb(rho_t)
    eref = emb.reference(F)
    gam, bet = layer.modulation(e[:, None], e[None, :], eref)  # [N, N, C], brute force

    def edge(i, j):
        return (gam[i, j] * F[j] + bet[i, j]).detach().numpy()

    ref = reference_cconv(x, x, F.numpy(), layer.weight.detach().numpy(), R,
                          edge_features=edge) + layer.bias.detach().numpy()
    for mode in ("classes", "edges"):
        out = layer(F, geom, DensityPlan(geom, rho, mode), emb)
        np.testing.assert_allclose(out.detach().numpy(), ref, rtol=1e-5, atol=1e-9)


def test_identity_at_reference_density():
    """eq. 7: γ = 1 and β = 0 at ρ_i = ρ_j = ρ_ref for any weights, so Γ = I."""
    x, _, _, _, _ = _scene(3, 4)
    n = len(x)
    torch.manual_seed(0)
    layer = DensityCConvLayer(5, 6, 3).double()
    emb = DensityEmbedding().double()
    _perturb_modulation(torch.nn.ModuleDict({"modulation": layer.modulation, "embedding": emb}))
    e = emb(torch.full((3,), 1000.0, dtype=torch.float64))
    gam, bet = layer.modulation(e, e, emb.reference(e))
    torch.testing.assert_close(gam, torch.ones_like(gam), rtol=0, atol=1e-13)
    torch.testing.assert_close(bet, torch.zeros_like(bet), rtol=0, atol=1e-13)
    plain = CConvLayer(5, 6, 3).double()
    plain.load_state_dict({"weight": layer.weight, "bias": layer.bias})
    geom = build_geometry(x, radius=R)
    F = torch.randn(n, 5, dtype=torch.float64)
    for mode in ("classes", "edges"):
        out = layer(F, geom, DensityPlan(geom, np.full(n, 1000.0), mode), emb)
        torch.testing.assert_close(out, plain(F, geom), rtol=1e-12, atol=1e-12)


class _Plain(CorrectionNet):
    name = "plain-test"


def test_dcdc_network_reduces_to_plain_cconv_network():
    x, v, _, wx, wn = _scene(3, 5)
    net = _perturb_modulation(_net("dcdc", 3))
    plain = _Plain(3, **SMALL).double()
    missing = plain.load_state_dict(net.state_dict(), strict=False)
    assert not missing.missing_keys  # every plain weight comes from the dcdc net
    rho = np.full(len(x), 1000.0)
    torch.testing.assert_close(net(x, v, rho, wx, wn), plain(x, v, rho, wx, wn),
                               rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("name", ["dcdc", "dcdc-antisym"])
def test_fast_path_equals_per_edge_path(name):
    x, v, rho, wx, wn = _scene(3, 5)
    net = _perturb_modulation(_net(name, 3))
    out = {}
    grads = {}
    for mode in ("classes", "edges"):
        net.cfg.density_mode = mode
        net.zero_grad()
        vt = torch.tensor(v, requires_grad=True)
        dx = net(x, vt, rho, wx, wn)
        dx.square().sum().backward()
        out[mode] = dx.detach()
        grads[mode] = [vt.grad.clone()] + [p.grad.clone() for p in net.parameters()]
    torch.testing.assert_close(out["classes"], out["edges"], rtol=1e-9, atol=1e-15)
    for a, b in zip(grads["classes"], grads["edges"]):
        torch.testing.assert_close(a, b, rtol=1e-8, atol=1e-14)


def test_gradcheck_modulated_network_inputs():
    x, v, rho, wx, wn = _scene(2, 4)
    net = _perturb_modulation(_net("dcdc", 2, channels=[3, 4, 4]))
    ctx = net.prepare(x, rho, wx)  # geometry is data: reuse it for every evaluation
    vt = torch.tensor(v, requires_grad=True)
    assert torch.autograd.gradcheck(lambda vv: net(x, vv, rho, wx, wn, ctx=ctx), (vt,))
    # and w.r.t. modulation and embedding weights (γ, β MLPs and φ get exact gradients)
    names = ["conv0_fluid.modulation.gamma_mlp.2.bias", "convs.1.modulation.beta_mlp.2.bias",
             "embedding.phi.0.weight"]
    params = dict(net.named_parameters())
    args = tuple(params[n].detach().clone().requires_grad_() for n in names)

    def f(*ws):
        return torch.func.functional_call(net, dict(zip(names, ws)), (x, v, rho, wx, wn),
                                          {"ctx": ctx})

    assert torch.autograd.gradcheck(f, args)


# ---------------------------------------------------------------------- networks
@pytest.mark.parametrize("name", sorted(NETWORKS))
@pytest.mark.parametrize("dim", [2, 3])
def test_networks_invariant_to_translation_and_order(name, dim):
    x, v, rho, wx, wn = _scene(dim, 4 if dim == 3 else 8)
    net = _perturb_modulation(_net(name, dim))
    dx = net(x, v, rho, wx, wn)
    assert dx.shape == x.shape and torch.isfinite(dx).all()
    shift = np.linspace(1.5, -2.0, dim)
    torch.testing.assert_close(net(x + shift, v, rho, wx + shift, wn), dx, rtol=1e-8, atol=1e-12)
    p = np.random.default_rng(0).permutation(len(x))
    q = np.random.default_rng(1).permutation(len(wx))
    torch.testing.assert_close(net(x[p], v[p], rho[p], wx[q], wn[q]), dx[p], rtol=1e-9,
                               atol=1e-13)


@pytest.mark.parametrize("mode", ["classes", "edges"])
@pytest.mark.parametrize("dtype", [torch.float64, torch.float32])
def test_antisymmetric_network_conserves_momentum(mode, dtype):
    x, v, rho, _, _ = _scene(3, 6)
    rho = rho * np.where(np.arange(len(x)) % 3 == 0, 1.0, 1.0)
    if mode == "edges":  # continuous densities too
        rho = rho * np.random.default_rng(2).uniform(0.9, 1.1, len(rho))
    net = _perturb_modulation(_net("dcdc-antisym", 3, density_mode=mode)).to(dtype)
    dx = net(x, v, rho, None, None).double()
    p = (torch.tensor(rho)[:, None] * dx).sum(0)
    scale = (torch.tensor(rho)[:, None] * dx).abs().sum(0)
    eps = 1e-12 if dtype == torch.float64 else 1e-5
    assert (p.abs() <= eps * scale).all(), (p, scale)
    # the plain dcdc net does not conserve it
    plain = _perturb_modulation(_net("dcdc", 3))
    dxp = plain(x, v, rho, None, None)
    assert (torch.tensor(rho)[:, None] * dxp).sum(0).abs().max() > 1e-3 * (
        torch.tensor(rho)[:, None] * dxp).abs().sum()


def test_build_network_errors():
    with pytest.raises(DcdcError, match="unknown network"):
        build_network("transformer", 3)
    with pytest.raises(DcdcError, match="unknown network option"):
        build_network("dcdc", 3, layers=7)
    with pytest.raises(DcdcError, match="dim"):
        build_network("dcdc", 4)
    with pytest.raises(DcdcError, match="normalize"):
        build_network("dcdc-antisym", 3, normalize=True)


# ---------------------------------------------------------------------- integrator
def test_step_is_algorithm_1():
    x, v, rho, wx, wn = _scene(2, 6)
    net = _net("dcdc", 2)
    g = (0.0, -9.81)
    x1, v1 = step(net, x, v, rho, wx, wn, dt=0.02, gravity=g)
    xs, vs = inertial(torch.tensor(x), torch.tensor(v), 0.02, g)
    torch.testing.assert_close(xs, torch.tensor(x + 0.02 * v + 0.5 * 0.02 ** 2 * np.array(g)))
    dx = net(xs, vs, rho, wx, wn)
    torch.testing.assert_close(x1, xs + dx)
    torch.testing.assert_close(v1, (x1 - torch.tensor(x)) / 0.02)
    # rollout = repeated steps
    xr, vr = rollout(net, x, v, rho, wx, wn, n_steps=2, dt=0.02, gravity=g)
    x2, v2 = step(net, x1, v1, rho, wx, wn, dt=0.02, gravity=g)
    torch.testing.assert_close(xr, x2)
    torch.testing.assert_close(vr, v2)


def test_unrolled_steps_are_differentiable():
    x, v, rho, wx, wn = _scene(3, 4)
    net = _net("dcdc", 3).float()
    xx, vv = torch.tensor(x, dtype=torch.float32), torch.tensor(v, dtype=torch.float32)
    x1, v1 = step(net, xx, vv, rho, wx, wn)
    x2, _ = step(net, x1, v1, rho, wx, wn)
    loss = (x2 - xx).square().mean()
    loss.backward()
    grads = [p.grad for p in net.parameters()]
    assert all(g is not None and torch.isfinite(g).all() for g in grads)
    assert net.convs[-1].weight.grad.abs().sum() > 0


# ---------------------------------------------------------------------- checkpoints
def test_checkpoint_round_trip(tmp_path):
    x, v, rho, wx, wn = _scene(3, 4)
    net = _perturb_modulation(_net("dcdc", 3, normalize=True))
    path = save_checkpoint(tmp_path / "m.pt", net, data={"dataset": "blocks", "frames": 12},
                           extra={"step": 5})
    model, ck = load_checkpoint(path, expect="dcdc", dim=3)
    model = model.double()
    assert ck["format"] == FORMAT and ck["data"]["frames"] == 12 and ck["extra"]["step"] == 5
    assert model.config() == net.config() and model.cfg.normalize
    torch.testing.assert_close(model(x, v, rho, wx, wn), net(x, v, rho, wx, wn))
    raw = torch.load(path, weights_only=True)  # plain, weights-only loadable
    assert set(raw) >= {"format", "format_version", "config", "state_dict", "code_version", "data",
                        "digest"}


def test_checkpoint_rejections(tmp_path):
    net = _net("cconv", 2)
    path = save_checkpoint(tmp_path / "c.pt", net)
    with pytest.raises(DcdcError, match="holds a 'cconv' network, expected 'dcdc'"):
        load_checkpoint(path, expect="dcdc")
    with pytest.raises(DcdcError, match="2-D model, expected 3-D"):
        load_checkpoint(path, dim=3)
    ck = torch.load(path, weights_only=True)

    def write(name, obj):  # a re-stamped digest: these test what comes after it
        p = tmp_path / name
        torch.save({**obj, "digest": digest(obj)}, p)
        return p

    with pytest.raises(DcdcError, match="format version 99"):
        load_checkpoint(write("v.pt", {**ck, "format_version": 99}))
    with pytest.raises(DcdcError, match="not a dcdc checkpoint"):
        load_checkpoint(write("o.pt", {"model": ck["state_dict"]}))
    with pytest.raises(DcdcError, match="unknown architecture"):
        load_checkpoint(write("a.pt", {**ck, "config": {**ck["config"], "name": "gns"}}))
    wrong = {**ck, "config": {**ck["config"], "channels": [16, 12, 12]}}
    with pytest.raises(DcdcError, match="weights do not fit"):
        load_checkpoint(write("s.pt", wrong))
    bad = tmp_path / "corrupt.pt"
    bad.write_bytes(path.read_bytes()[:200])
    with pytest.raises(DcdcError, match="corrupt"):
        load_checkpoint(bad)
    with pytest.raises(DcdcError, match="does not exist"):
        load_checkpoint(tmp_path / "nope.pt")
    # a pickle that needs code to load is refused by weights_only
    with pytest.raises(DcdcError, match="corrupt or not a dcdc checkpoint"):
        load_checkpoint(write("evil.pt", {"format": FORMAT, "obj": argparse.Namespace(a=1)}))


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
@pytest.mark.parametrize("name", sorted(NETWORKS))
def test_cuda_equals_cpu(name):
    """On a GPU (the sparse matrices assembled on the device, cconv._sparse_matrix) the
    step and all its gradients equal the CPU's numba path in float64."""
    import copy

    x, v, rho, wx, wn = _scene(3, 4)
    base = _perturb_modulation(_net(name, 3))
    res = {}
    for dev in ("cpu", "cuda"):
        net = copy.deepcopy(base).to(dev)
        vt = torch.tensor(v, requires_grad=True, device=dev)
        dx = net(x, vt, rho, wx, wn)
        dx.square().sum().backward()
        res[dev] = [t.detach().cpu() for t in [dx, vt.grad] + [p.grad for p in net.parameters()]]
    for a, b in zip(res["cpu"], res["cuda"]):
        torch.testing.assert_close(b, a, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", sorted(NETWORKS))
def test_pure_torch_backend_equals_numba_backend(name):
    """The CUDA code path (sparse CSR products, no numba in the layers) gives the same numbers."""
    x, v, rho, wx, wn = _scene(3, 4)
    net = _perturb_modulation(_net(name, 3))
    res = {}
    for backend in ("numba", "torch"):
        net.set_backend(backend)
        net.zero_grad()
        vt = torch.tensor(v, requires_grad=True)
        dx = net(x, vt, rho, wx, wn)
        dx.square().sum().backward()
        res[backend] = [dx.detach(), vt.grad] + [p.grad for p in net.parameters()]
    for a, b in zip(res["numba"], res["torch"]):
        torch.testing.assert_close(a, b, rtol=1e-9, atol=1e-14)


@pytest.mark.parametrize("name", sorted(NETWORKS))
def test_empty_tiny_and_wall_less_systems(name):
    net = _net(name, 3)
    for n in (0, 1, 2):
        x = np.random.default_rng(n).uniform(0, 0.05, (n, 3))
        for walls in (None, np.zeros((0, 3)), np.full((3, 3), 0.01)):
            wn = None if walls is None else np.tile([0, 1.0, 0], (len(walls), 1))
            x1, v1 = step(net, x, np.zeros((n, 3)), np.full(n, 500.0), walls, wn)
            assert x1.shape == (n, 3) and torch.isfinite(x1).all() and torch.isfinite(v1).all()


def test_continuous_densities_choose_the_per_edge_path():
    x, v, _, wx, wn = _scene(3, 4)
    rho = np.random.default_rng(3).uniform(500, 3000, len(x))
    net = _net("dcdc", 3)
    ctx = net.prepare(x, rho, wx)
    assert ctx.plan.mode == "edges"
    ctx2 = net.prepare(x, np.round(rho, -3), wx)
    assert ctx2.plan.mode == "classes"
    assert torch.isfinite(net(x, v, rho, wx, wn, ctx=ctx)).all()


def test_step_from_particle_system():
    from dcdc.model.integrator import system_inputs
    from dcdc.particles import ParticleSystem, Phase

    x, v, rho, wx, wn = _scene(2, 5)
    ps = ParticleSystem(2, 0.025, x, v, (rho > 1000).astype(int),
                        [Phase("light", 500.0), Phase("heavy", 2000.0)], wx, wn, (0, -9.81),
                        (np.full(2, -1.0), np.full(2, 1.0)))
    net = _net("dcdc", 2)
    x1, v1 = step(net, **system_inputs(ps), dt=0.02)
    x2, v2 = step(net, x, v, ps.rest_density, wx, wn, dt=0.02, gravity=(0, -9.81))
    torch.testing.assert_close(x1, x2)


def test_unconditioned_antisymmetric_layer_pair_terms_cancel():
    from dcdc.model.layers import AntisymCConvLayer

    x, _, rho, _, _ = _scene(2, 7)
    torch.manual_seed(0)
    layer = AntisymCConvLayer(4, 2, 2, conditioned=False).double()
    geom = build_geometry(x, radius=R)
    F = torch.randn(len(x), 4, dtype=torch.float64)
    out = layer(F, geom, DensityPlan(geom, rho))
    assert out.sum(0).abs().max() < 1e-12 * out.abs().sum()
    ref = reference_cconv(x, x, F.numpy(), layer.filter().detach().numpy(), R,
                          edge_features=lambda i, j: (F[i] + F[j]).numpy())
    np.testing.assert_allclose(out.detach().numpy(), ref, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("name", sorted(NETWORKS))
def test_a_batch_of_scenes_equals_the_scenes_one_by_one(name):
    """One forward pass over concatenated scenes (per-scene search with index offsets):
    overlapping scenes do not interact, and gradients equal the sum of the separate ones."""
    from dcdc.model.networks import Scenes

    net = _perturb_modulation(_net(name, 2))
    a, b = _scene(2, 5, seed=0), _scene(2, 6, seed=3)  # same place in space
    sep = [step(net, *s[:2], s[2], s[3], s[4], dt=0.02)[0] for s in (a, b)]
    cat = [np.concatenate([a[k], b[k]]) for k in range(5)]
    scenes = Scenes.from_counts([len(a[0]), len(b[0])], [len(a[3]), len(b[3])])
    x1, _ = step(net, *cat, dt=0.02, scenes=scenes)
    torch.testing.assert_close(x1, torch.cat(sep))
    # a scene without walls in the batch
    scenes = Scenes.from_counts([len(a[0]), len(b[0])], [0, len(b[3])])
    x2, _ = step(net, cat[0], cat[1], cat[2], b[3], b[4], dt=0.02, scenes=scenes)
    torch.testing.assert_close(x2[:len(a[0])], step(net, a[0], a[1], a[2], dt=0.02)[0])
    with pytest.raises(DcdcError, match="scene offsets cover"):
        step(net, *cat, dt=0.02, scenes=Scenes.from_counts([3, 4], [1, 1]))


def test_step_rejects_inputs_that_would_give_nan_or_a_traceback():
    x, v, rho, wx, wn = _scene(2, 4)
    net3 = _net("dcdc", 3)
    with pytest.raises(DcdcError, match="3-D network needs positions"):
        step(net3, x, v, rho, None, None)
    net = _net("dcdc", 2)
    with pytest.raises(DcdcError, match="density has 15 values for 16 particles"):
        step(net, x, v, rho[:-1], wx, wn)
    with pytest.raises(DcdcError, match="dt must be a finite number > 0"):
        step(net, x, v, rho, wx, wn, dt=0.0)
    with pytest.raises(DcdcError, match="densities must be finite and > 0"):
        step(net, x, v, -rho, wx, wn)
    with pytest.raises(DcdcError, match="wall normals"):
        step(net, x, v, rho, wx, wn[:3])
    with pytest.raises(DcdcError, match="velocities"):
        step(net, x, v[:3], rho, wx, wn)


# ---------------------------------------------------------------------- fixed costs
def _reference_context(net, x, rho, wx):
    """The step context built the straightforward way: a fresh float64 search and geometry per call
    (``radius_search`` + ``build_geometry`` with float64 weights, no cached wall grid) and the
    eager density plan. The optimised :meth:`CorrectionNet.prepare` must give the same numbers."""
    from dcdc.model.networks import StepContext
    from dcdc.neighbors import radius_search

    c = net.cfg
    x = np.asarray(x, dtype=np.float64)
    fluid = build_geometry(x, None, c.radius, c.kernel_size, True, c.normalize,
                           neighbors=radius_search(x, c.radius, exclude_self=True))
    wall = build_geometry(x, wx, c.radius, c.kernel_size, False, c.normalize,
                          neighbors=radius_search(x, c.radius, wx))
    plan = DensityPlan(fluid, rho, c.density_mode, c.max_classes) if (
        net.conditioned or net.antisymmetric) else None
    return StepContext(fluid, wall, plan)


def _outputs_and_grads(net, x, v, rho, wx, wn, ctx):
    net.zero_grad(set_to_none=True)
    vt = torch.tensor(v, dtype=torch.float32, requires_grad=True)
    dx = net(torch.tensor(x, dtype=torch.float32), vt, rho, wx, wn, ctx=ctx)
    (dx.square().sum() + dx.sin().sum()).backward()
    grads = [vt.grad] + [p.grad if p.grad is not None else torch.zeros_like(p)
                         for p in net.parameters()]
    return dx.detach(), grads


@pytest.mark.slow
@pytest.mark.parametrize("name", list(NETWORKS))
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("mode", ["classes", "edges"])
def test_optimised_prepare_equals_reference_path(name, dim, mode):
    """float32 weights written by the geometry kernel, the cached wall grid, the lazy density
    plan and the register-summed output layer: outputs and every gradient equal the previous
    path to 1e-5 relative in float32 (over two steps, the second reusing the wall grid)."""
    torch.manual_seed(0)
    net = build_network(name, dim, channels=[8, 12, 12], density_mode=mode)
    x, v, rho, wx, wn = _scene(dim, 5 if dim == 3 else 9)
    for k in range(2):
        xk = (x + 0.01 * k).astype(np.float32).astype(np.float64)  # the net sees float32
        ref, ref_g = _outputs_and_grads(net, xk, v, rho, wx, wn, _reference_context(net, xk, rho, wx))
        ctx = net.prepare(torch.tensor(xk, dtype=torch.float32), rho, wx)
        new, new_g = _outputs_and_grads(net, xk, v, rho, wx, wn, ctx)
        rctx = _reference_context(net, xk, rho, wx)
        for g_new, g_ref in ((ctx.fluid, rctx.fluid), (ctx.wall, rctx.wall)):
            assert np.array_equal(g_new.row_splits, g_ref.row_splits)
            assert np.array_equal(g_new.src, g_ref.src) and np.array_equal(g_new.cells, g_ref.cells)
            assert g_new.weights.dtype == np.float32
            assert np.array_equal(g_new.weights, g_ref.weights.astype(np.float32))
        assert torch.allclose(new, ref, rtol=0, atol=1e-5 * float(ref.abs().max()))
        scale = max(float(g.abs().max()) for g in ref_g)
        for a, b in zip(new_g, ref_g):
            tol = 1e-5 * max(float(b.abs().max()), 1e-3 * scale)  # floor: cancelling sums
            assert torch.allclose(a, b, rtol=0, atol=tol)
    assert net._wall_grids.builds == 1  # static walls: binned once
    net.prepare(x, rho, wx + 0.01)  # moved walls: rebuilt
    assert net._wall_grids.builds == 2


def test_wall_grid_cache_follows_scene_batches():
    """The cached wall grids of a batch of scenes give the per-scene search exactly."""
    from dcdc.model.networks import Scenes

    net = _net("dcdc", 3)
    x, _, rho, wx, _ = _scene(3, 4)
    xb = np.concatenate([x, x + 3.0])
    wb = np.concatenate([wx, wx[:10] + 3.0])
    sc = Scenes.from_counts([len(x)] * 2, [len(wx), 10])
    ctx = net.prepare(xb, np.concatenate([rho, rho]), wb, scenes=sc)
    ctx2 = net.prepare(xb, np.concatenate([rho, rho]), wb, scenes=sc)
    assert net._wall_grids.builds == 1
    from dcdc.model.networks import _search

    ref = _search(xb, net.cfg.radius, wb, sc)
    for c in (ctx, ctx2):
        assert np.array_equal(c.wall.row_splits, ref.row_splits)
        assert np.array_equal(c.wall.src, ref.index)
    net.prepare(xb, np.concatenate([rho, rho]), wb, scenes=Scenes.from_counts([len(x)] * 2, [20, 30]))
    assert net._wall_grids.builds == 2  # other scene offsets: rebuilt


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_inference_modulated_rows_equal_the_autograd_rows(dtype):
    """Without gradients the class path's Γ rows come from one numba pass: bit-identical to
    the torch expression that training differentiates."""
    from dcdc.model.modulation import PairModulation

    x, _, rho, _, _ = _scene(3, 4)
    torch.manual_seed(3)
    mod, emb = PairModulation(8, 6).to(dtype), DensityEmbedding(8).to(dtype)
    plan = DensityPlan(build_geometry(x, radius=R, dtype=dtype), rho)
    f = torch.randn(len(x), 6, dtype=dtype)
    with torch.no_grad():
        fast, g1 = plan.modulated(f, mod, emb)
    slow, g2 = plan.modulated(f, mod, emb)
    assert g1 is g2 and slow.requires_grad and not fast.requires_grad
    assert torch.equal(fast, slow.detach())


def test_one_pass_search_bound_follows_the_counts():
    """The one-pass bound tracks the largest neighbour count; a clump far above the mean
    switches to the two-pass search (no [N, huge] scratch); results are the same."""
    from dcdc.model.networks import _empty_neighbors, _next_capacity
    from dcdc.neighbors import radius_search

    x = _block(3, 6)
    nb = radius_search(x, R, exclude_self=True)
    assert _next_capacity(nb) == max(32, int(1.25 * nb.counts.max()) + 8)
    big = _block(3, 12)
    clump = np.concatenate([big, np.repeat(big[:1], 200, axis=0)])
    assert _next_capacity(radius_search(clump, R, exclude_self=True)) is None
    assert _next_capacity(_empty_neighbors(0)) == 32
    net = _net("cconv", 3)
    rho = np.full(len(clump), 1000.0)
    ctx = net.prepare(clump, rho)
    assert net._search_caps[0] is None
    ref = radius_search(clump, net.cfg.radius, exclude_self=True)
    np.testing.assert_array_equal(ctx.fluid.src, ref.index)
    net.prepare(x, rho[:len(x)])  # back to the one-pass search
    assert net._search_caps[0] is not None
