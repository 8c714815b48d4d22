"""Scores of learned models against SPH ground truth (docs/evaluation.md).

:func:`score_trajectory` runs one model on one ground-truth trajectory and returns plain
numbers (JSON-ready) plus per-frame curves; :func:`aggregate` averages over trajectories.
Every metric is defined in docs/evaluation.md and computed with :mod:`dcdc.metrics`.
"""
from __future__ import annotations

import math

import numpy as np
import torch

from .. import metrics as M
from ..errors import DcdcError
from . import CONTACT_DEFAULT
from .rollout import Guard, NeuralSimulator, run
from .start import check_start_frame

MM = 1e3  # metres -> millimetres
PURITY_RADIUS = 4.0  # neighbour purity within this many particle radii (the SPH support h)
MIXING_EVERY = 0.5  # seconds between the frames of the mixing curves


def _finite(v):
    """JSON-friendly float: NaN/inf become None."""
    v = float(v)
    return v if math.isfinite(v) else None


def rest_volume(radius: float, dim: int, support: float = 4.0) -> float:
    """The SPH solver's rest volume per particle V0 (lattice volume of spacing 2r, h = support·r);
    particle masses are ρ0 V0."""
    from ..sph.kernels import lattice_volume
    return lattice_volume(2 * radius, support * radius, dim)


def number_density(x, radius: float, wall_x, support: float = 4.0):
    """ψ_i = V0 Σ_j W_ij + Σ_b V_b W_ib with the SPH solver's cubic kernel (h = support·r),
    lattice volume V0 and Akinci wall volumes V_b (docs/sph.md): the solver's own density
    estimate, for a predicted state as for the ground truth. Returns (ψ [N], V0)."""
    from ..neighbors import radius_search
    from ..sph.boundary import wall_volumes
    from ..sph.terms import edge_kernels

    x = np.ascontiguousarray(x, dtype=np.float64)
    h = support * radius
    V0 = rest_volume(radius, x.shape[1], support)
    nb = radius_search(x, h)
    W, _ = edge_kernels(x, x, nb.row_splits, nb.index, h)
    psi = V0 * np.bincount(nb.receivers(), weights=W, minlength=len(x))
    wall_x = np.ascontiguousarray(wall_x, dtype=np.float64)
    if len(wall_x):
        Vb = wall_volumes(wall_x, h, V0)
        nw = radius_search(x, h, wall_x)
        Ww, _ = edge_kernels(x, wall_x, nw.row_splits, nw.index, h)
        psi += np.bincount(nw.receivers(), weights=Vb[nw.index] * Ww, minlength=len(x))
    return psi, V0


def one_two_step_errors(model, traj, stride: int = 5) -> tuple[float, float, int]:
    """DeepLagrangianFluids' n+1 and n+2 errors [m]: from the ground-truth state at every
    ``stride``-th frame f, one and two network steps, compared with frames f+1 and f+2 (mean
    per-particle distance of the particles present at f, averaged over the starts).
    Returns (err_n1, err_n2, number of starts)."""
    from ..model.integrator import step

    e1, e2 = [], []
    T = traj.n_frames
    rho = traj.density.astype(np.float64)
    wx, wn = torch.as_tensor(traj.wall_x), torch.as_tensor(traj.wall_n)
    g = torch.as_tensor(traj.gravity)
    pos, vel = traj.position, traj.velocity
    for f in range(0, T - 2, stride):
        act = traj.active(f)
        if not act.any():
            continue
        with torch.no_grad():
            x1, v1 = step(model, pos[f][act].astype(np.float64), vel[f][act].astype(np.float64),
                          rho[act], wx, wn, None, g)
            x2, _ = step(model, x1, v1, rho[act], wx, wn, None, g)
        e1.append(M.position_error(x1.double().numpy(), pos[f + 1][act]))
        e2.append(M.position_error(x2.double().numpy(), pos[f + 2][act]))
    return (float(np.mean(e1)) if e1 else float("nan"),
            float(np.mean(e2)) if e2 else float("nan"), len(e1))


def physical_state(x, phase, phases, radius, wall_x, domain_min, active):
    """Physical metrics of one state (predicted or true): per-phase centre-of-mass and median
    heights above the domain floor, stratification order, neighbour purity, per-phase
    volumes and the mean compression (docs/evaluation.md)."""
    x, phase = x[active], phase[active]
    P = len(phases)
    rho = np.array([p.density for p in phases])
    floor = float(domain_min[1])
    psi, V0 = number_density(x, radius, wall_x)
    return {
        "com_height": (M.phase_heights(x, phase, P) - floor),
        "median_height": (M.phase_heights(x, phase, P, stat="median") - floor),
        "order_ok": M.density_order_ok(x, phase, rho, stat="median"),
        "order_ok_com": M.density_order_ok(x, phase, rho, stat="mean"),
        "purity": M.neighbour_purity(x, phase, PURITY_RADIUS * radius),
        "purity_per_phase": M.neighbour_purity_per_phase(x, phase, PURITY_RADIUS * radius, P),
        "volumes": M.phase_volumes(psi, phase, V0, P),
        "density_error": M.density_error(psi),
    }


def compare_states(pred_x, true_x, traj, active) -> tuple[dict, dict, np.ndarray]:
    """:func:`physical_state` of a predicted and a true frame of ``traj`` (particles
    ``active``) and the relative error of each phase's centre-of-mass height,
    |h_pred - h_true| / |h_true| (docs/evaluation.md; its largest value is "COM err").
    ``pred`` also gets the layering against the truth (:func:`layering`)."""
    dmin = np.asarray(traj.attrs["domain_min"], dtype=np.float64)
    pred, true = (physical_state(np.asarray(x, dtype=np.float64), traj.phase, traj.phases,
                                 traj.radius, traj.wall_x, dmin, active)
                  for x in (pred_x, true_x))
    with np.errstate(invalid="ignore", divide="ignore"):
        com_rel = np.abs(pred["com_height"] - true["com_height"]) / np.abs(true["com_height"])
    pred.update(layering(pred_x, true_x, traj.phase, len(traj.phases), active,
                         pred["purity_per_phase"], true["purity_per_phase"]))
    return pred, true, com_rel


def layering(pred_x, true_x, phase, n_phases: int, active, purity, purity_true) -> dict:
    """How a predicted state's layers compare with the truth's (docs/evaluation.md,
    "Layers"): per phase the 1-Wasserstein distance of the height distributions
    (:func:`dcdc.metrics.height_distance`) relative to the true column's depth, the ratio
    of the per-phase neighbour purities, and the verdict :func:`dcdc.metrics.layers_like`."""
    xp = np.asarray(pred_x, dtype=np.float64)[active]
    xt = np.asarray(true_x, dtype=np.float64)[active]
    ph = np.asarray(phase)[active]
    hd = M.height_distance(xp, ph, xt, ph, n_phases)
    depth = M.column_depth(xt)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.asarray(purity, float) / np.asarray(purity_true, float)
        rel = hd / depth
    return {"height_w1": hd, "height_w1_rel": rel, "purity_ratio": ratio,
            "layers_ok": M.layers_like(purity, purity_true, hd, depth)}


def _nanmin(a):
    a = np.asarray(a, float)
    return _finite(np.nanmin(a)) if np.isfinite(a).any() else None


def _nanmax(a):
    a = np.asarray(a, float)
    return _finite(np.nanmax(a)) if np.isfinite(a).any() else None


def mixing_curves(pred_pos, true_pos, traj, s0: int, steps: int, radius: float) -> dict:
    """The mixing over time against the truth at the same times (docs/evaluation.md,
    "Layers"): every :data:`MIXING_EVERY` seconds of the rollout (and at its last frame),
    per phase the neighbour purity of the prediction and of the truth and the height
    distance relative to the true column. Rollout frame k is ground-truth frame s0 + k."""
    P = len(traj.phases)
    every = max(1, int(round(MIXING_EVERY / traj.frame_dt)))
    ks = sorted(set(range(0, steps + 1, every)) | {steps})
    out = {"time": [], "purity_pred": [], "purity_true": [], "height_w1_rel": []}
    for k in ks:
        act = traj.active(s0 + k)
        xp, xt = pred_pos[k][act].astype(np.float64), true_pos[s0 + k][act].astype(np.float64)
        ph = traj.phase[act]
        pp = M.neighbour_purity_per_phase(xp, ph, PURITY_RADIUS * radius, P)
        pt = M.neighbour_purity_per_phase(xt, ph, PURITY_RADIUS * radius, P)
        rel = M.height_distance(xp, ph, xt, ph, P) / M.column_depth(xt)
        out["time"].append(float(traj.time[s0 + k]))
        out["purity_pred"].append([_finite(v) for v in pp])
        out["purity_true"].append([_finite(v) for v in pt])
        out["height_w1_rel"].append([_finite(v) for v in rel])
    return out


def displace(system, perturb: float, seed: int):
    """``system`` with every fluid position displaced in place by ``perturb`` metres rms per
    component (normal, seeded by ``seed``; velocities and walls as they are): a member of an
    ensemble of starts that differ far below the particle spacing. 0 leaves it as it is."""
    if perturb:
        system.x += perturb * np.random.default_rng(seed).standard_normal(system.x.shape)
    return system


def perturbed_start(traj, frame: int, perturb: float, seed: int):
    """The ground-truth state at ``frame``, displaced by :func:`displace` (``perturb`` 0 =
    the state as stored)."""
    return displace(traj.system(frame), perturb, seed)


def score_trajectory(model, traj, stride: int = 5, steps: int | None = None,
                     guard: Guard | None = None, ot_points: int = 2000,
                     contact: bool | None = CONTACT_DEFAULT, start_frame: int = 0, perturb: float = 0.0,
                     seed: int = 0, one_two_step: bool = True) -> dict:
    """All scores of ``model`` on ground-truth trajectory ``traj`` (a
    :class:`~dcdc.data.dataset.Trajectory`): n+1/n+2 errors (the network alone, over the
    whole trajectory; skipped, None, with ``one_two_step`` False), a rollout from frame
    ``start_frame`` (default 0: the scene's initial state; displaced as
    :func:`perturbed_start` says with ``perturb`` > 0) over ``steps`` (default: every
    remaining frame; with the walls' contact where ``contact`` says, None: the model's
    default, :func:`~dcdc.evaluate.rollout.uses_contact`) with its per-frame
    errors against the frames it reaches, and the final-state physics. The rollout's
    per-frame curves are under ``"curves"``."""
    from ..model.checkpoint import check_compatible

    check_compatible(model, dim=traj.dim, radius=traj.radius, frame_dt=traj.frame_dt,
                     what=f"trajectory {traj.name}")
    traj.check_values()  # every frame feeds the n+1/n+2 errors and the comparisons
    s0 = int(start_frame)
    check_start_frame(traj.name, traj.n_frames, s0, flag="start frame")
    n1, n2, starts = (one_two_step_errors(model, traj, stride) if one_two_step
                      else (float("nan"), float("nan"), 0))
    left = traj.n_frames - 1 - s0
    n = left if steps is None else min(int(steps), left)
    sim = NeuralSimulator(model, perturbed_start(traj, s0, perturb, seed), guard=guard,
                          time=float(traj.time[s0]), contact=contact)
    ro = run(sim, n)
    K = ro.steps
    phases, phase = traj.phases, traj.phase
    mass = traj.density.astype(np.float64) * rest_volume(traj.radius, traj.dim)
    pos_t, vel_t = traj.position, traj.velocity
    near, perr, ke_p, ke_t, mom = [], [], [], [], []
    for k in range(1, K + 1):  # rollout frame k is ground-truth frame s0 + k
        act = traj.active(s0 + k)
        xp, xt = ro.position[k][act], pos_t[s0 + k][act]
        near.append(M.nearest_error(xp, xt))
        perr.append(M.position_error(xp, xt))
        ke_p.append(M.kinetic_energy(ro.velocity[k][act], mass[act]))
        ke_t.append(M.kinetic_energy(vel_t[s0 + k][act], mass[act]))
        dP = (M.momentum(ro.velocity[k][act], mass[act])
              - M.momentum(vel_t[s0 + k][act], mass[act]))
        mom.append(float(np.linalg.norm(dP)) / max(float(mass[act].sum()), 1e-30))
    act = traj.active(s0 + K)
    pred, true, com_rel = compare_states(ro.position[K], pos_t[s0 + K], traj, act)
    w2 = [M.wasserstein_distance(ro.position[K][act & (phase == p)],
                                 pos_t[s0 + K][act & (phase == p)], max_points=ot_points)
          for p in range(len(phases)) if (act & (phase == p)).any()]
    mixing = mixing_curves(ro.position, pos_t, traj, s0, K, traj.radius)
    ke_scale = float(np.mean(ke_t)) if ke_t else float("nan")
    st = ro.stopped
    vol_err = M.volume_error(pred["volumes"], true["volumes"])
    return {
        "trajectory": traj.name, "particles": traj.n_particles, "phases": len(phases),
        "frames": traj.n_frames, "start_frame": s0, "steps_requested": n, "steps": K,
        "stable": st is None, "stop_cause": st.cause if st else "",
        "stopped": str(st) if st else "", "steps_to_failure": st.step if st else None,
        "starts_n1n2": starts,
        "err_n1_mm": _finite(MM * n1), "err_n2_mm": _finite(MM * n2),
        "rollout_mm": _finite(MM * np.mean(near)) if near else None,
        "position_mm": _finite(MM * np.mean(perr)) if perr else None,
        "w2_mm": _finite(MM * np.mean(w2)) if w2 else None,
        "w2_mm_per_phase": [_finite(MM * s) for s in w2],
        "ke_error": _finite(np.mean(np.abs(np.subtract(ke_p, ke_t))) / ke_scale) if ke_t else None,
        "momentum_error": _finite(np.mean(mom)) if mom else None,
        "com_height_error": _finite(np.nanmax(com_rel)) if np.isfinite(com_rel).any() else None,
        "com_height_pred": [_finite(h) for h in pred["com_height"]],
        "com_height_true": [_finite(h) for h in true["com_height"]],
        "order_ok": bool(pred["order_ok"]), "order_ok_true": bool(true["order_ok"]),
        "order_ok_com": bool(pred["order_ok_com"]),
        "purity": _finite(pred["purity"]), "purity_true": _finite(true["purity"]),
        "purity_per_phase": [_finite(v) for v in pred["purity_per_phase"]],
        "purity_per_phase_true": [_finite(v) for v in true["purity_per_phase"]],
        "purity_ratio_min": _nanmin(pred["purity_ratio"]),
        "height_w1_mm_per_phase": [_finite(MM * v) for v in pred["height_w1"]],
        "height_w1_rel_max": _nanmax(pred["height_w1_rel"]),
        "layers_ok": bool(pred["layers_ok"]),
        "volume_error": _finite(np.nanmax(np.abs(vol_err))) if np.isfinite(vol_err).any() else None,
        "density_error": _finite(pred["density_error"]),
        "density_error_true": _finite(true["density_error"]),
        "in_walls_max": int(ro.in_walls.max()) if len(ro.in_walls) else 0,
        "in_walls_mean": _finite(ro.in_walls.mean()) if len(ro.in_walls) else 0.0,
        "entered_walls": int(ro.entered_walls),
        "contact": bool(sim.uses_contact),
        "contacts_per_step": _finite(ro.contacts.mean()) if len(ro.contacts) else 0.0,
        "ms_per_step": _finite(ro.ms_per_step),
        "s_per_simulated_s": _finite(ro.ms_per_step / 1e3 / traj.frame_dt),
        "sph_s_per_simulated_s": _sph_cost(traj),
        "curves": {"time": ro.time[1:].tolist(), "rollout_mm": [MM * e for e in near],
                   "position_mm": [MM * e for e in perr], "ke_pred": ke_p, "ke_true": ke_t,
                   "in_walls": ro.in_walls.tolist(), "mixing": mixing},
    }


MEMBER_KEYS = ("com_height_error", "rollout_mm", "w2_mm", "purity", "purity_ratio_min",
               "height_w1_rel_max", "layers_ok", "order_ok", "stable", "steps")


def score_members(model, traj, members: int = 1, perturb: float = 1e-6, **kw) -> dict:
    """Scores that show how much of a rollout's error is chaos: :func:`score_trajectory`
    from the stored start (member 0, whose row this is) and from ``members`` - 1 starts
    displaced by ``perturb`` metres rms (members k = 1, 2, ...: seed k). Long rollouts of
    these flows are chaotic: rounding alone (another CPU's vector width) moves a 2-D
    hourglass rollout's COM error from 0.05 to 0.01 (docs/evaluation.md, "Ensembles"), so
    one rollout is one sample. With ``members`` > 1 the row gets ``"members"``: each
    member's final-state scores (:data:`MEMBER_KEYS`) and the COM error's mean, min and max
    over the members."""
    if members < 1:
        raise DcdcError(f"members must be >= 1 (got {members})")
    if perturb < 0 or not math.isfinite(perturb):
        raise DcdcError(f"perturb must be a finite length >= 0 m (got {perturb})")
    row = score_trajectory(model, traj, **kw)
    if members == 1:
        return row
    rows = [row] + [score_trajectory(model, traj, perturb=perturb, seed=k, one_two_step=False,
                                     **kw) for k in range(1, members)]
    ens = {"n": members, "perturb_m": perturb, **{k: [r[k] for r in rows] for k in MEMBER_KEYS}}
    com = [c for c in ens["com_height_error"] if c is not None]
    ens.update({"com_height_error_mean": _finite(np.mean(com)) if com else None,
                "com_height_error_min": _finite(min(com)) if com else None,
                "com_height_error_max": _finite(max(com)) if com else None})
    return {**row, "members": ens}


def _sph_cost(traj):
    """Wall seconds per simulated second the SPH solver took to make ``traj`` (from its
    metadata: generated on some machine at some time, not in this run)."""
    try:
        wall = float(traj.attrs.get("wall_time_s") or "nan")
    except (TypeError, ValueError):
        return None
    sim = (traj.n_frames - 1) * traj.frame_dt
    return _finite(wall / sim) if sim > 0 else None


NUMERIC = ("err_n1_mm", "err_n2_mm", "rollout_mm", "position_mm", "w2_mm", "ke_error",
           "momentum_error", "com_height_error", "purity", "purity_true", "purity_ratio_min",
           "height_w1_rel_max", "volume_error",
           "density_error", "density_error_true", "in_walls_max", "entered_walls", "contacts_per_step",
           "ms_per_step",
           "s_per_simulated_s", "sph_s_per_simulated_s")


def aggregate(rows: list[dict]) -> dict:
    """Means over trajectories of the numeric scores (None where no trajectory has one),
    the fraction with the right final order, the stable count and the fewest steps."""
    out = {"trajectories": len(rows)}
    for k in NUMERIC:
        vals = [r[k] for r in rows if r.get(k) is not None]
        out[k] = float(np.mean(vals)) if vals else None
    out["order_ok"] = float(np.mean([r["order_ok"] for r in rows])) if rows else None
    out["layers_ok"] = float(np.mean([r["layers_ok"] for r in rows])) if rows else None
    out["order_ok_true"] = float(np.mean([r["order_ok_true"] for r in rows])) if rows else None
    out["stable"] = int(sum(r["stable"] for r in rows))
    out["steps_min"] = int(min((r["steps"] for r in rows), default=0))
    return out
