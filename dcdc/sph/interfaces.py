"""Interfacial tension between phase pairs (docs/sph.md, "Interfacial tension").

``interfacial_tension = {"a/b" = σ_ab}`` [N/m; per unit depth in 2-D] with one of three
models (``SPHConfig.interfacial_model``):

**"curvature": the continuum surface force with an estimated curvature** (Brackbill, Kothe &
Zemach 1992, J. Comput. Phys. 100; in SPH Morris 2000, Int. J. Numer. Meth. Fluids 33, and
Adami, Hu & Adams 2010, J. Comput. Phys. 229). Per phase pair (a, b) a colour c = 1 on a,
0 on b, its gradient in difference form ∇c_i = V0 Σ_j (c_j − c_i) G_ij (the pair's
particles only), the curvature κ = −∇·n̂ of the unit normal n̂ = ∇c/|∇c| over the interface
band |∇c| > 0.01/h with the kernel-gradient-corrected divergence (exact for a linear normal
field: Adami et al.'s reproducing divergence is its isotropic special case, and reads 17 %
high in a band two rows wide on each side), smoothed along the band, and the force
per volume

    a_i = (σ_ab / L) κ̄_i ∇c_i / ρ0_i,

with L the lattice normalisation below; where the interface meets a wall ∇c loses its
wall-normal part (a contact angle of 90°, :func:`wall_contact`). The force is normal to the
interface: no tension along the band, so nothing clumps and no background pressure is
needed. It is a gradient
(of σκc/L) wherever κ is uniform, the gradient in the pressure force's difference form, so
a pressure step σκ balances it: measured on the validation drops (2.5 s, no gravity)
Δp = 0.93 / 0.92 σ/R (2-D quick / full) and 0.92 / 0.93 · 2σ/R (3-D quick / full),
round within 6 % (docs/sph.md, "Interfacial tension"). Not pairwise antisymmetric: the net
force on a closed drop is zero only as far as the discrete ∮ κ n̂ dA is (< 1 % of the
inward force on a lattice drop).

**"csf": the continuum surface force in its stress-tensor form.** Brackbill, Kothe
& Zemach (1992, "A continuum method for modeling surface tension", J. Comput. Phys. 100)
smear the surface force σκn̂δ_s over the interface through the gradient of a colour
function c. Lafaurie et al. (1994, "Modelling merging and fragmentation in multiphase flows
with SURFER", J. Comput. Phys. 113, eq. 8) write the same force as the divergence of the
capillary stress

    Π = σ (|∇c| I − ∇c ⊗ ∇c / |∇c|) = σ |∇c| (I − n̂ n̂),       f = ∇·Π,

a tension σ|∇c| along the interface and nothing across it: ∇·Π = −σ (∇·n̂) n̂ |∇c| plus
tangential terms that vanish on a uniform interface, i.e. σκ n̂ δ_s with no curvature to
estimate. Hu & Adams (2006, "A multi-phase SPH method for macroscopic and mesoscopic
flows", J. Comput. Phys. 213, eqs. 13-17 and §2.4) discretise it in SPH with one colour
function per phase pair and the antisymmetric pair form of the pressure term; here, in the
solver's volume form (docs/sph.md, "Pressure force"),

    ∇c^k_i = V0 Σ_j (c^k_j − c^k_i) G_ij,     c^k_j = 1 if j is of phase k, else 0,
    Π_i = Σ_{k ≠ a} (σ_ak / L) (|∇c^k_i| I − ∇c^k_i ⊗ ∇c^k_i / |∇c^k_i|)    (i of phase a),
    a_i = (1/ρ0_i) [ V0 Σ_j (Π_i + Π_j)·G_ij + Π_i·S_b,i ],

the same operator as the pressure force with −p I replaced by Π: the pair force
V0² (Π_i + Π_j)·G_ij is antisymmetric, so momentum is conserved, and the walls (S_b, as for
the pressure with β = 1) continue the interface's stress into the wall, so that an interface
meeting a wall feels no pull along it (contact angle 90°). Hu & Adams use the traceless
Π/σ = |∇c| I/d − ∇c∇c/|∇c|; that differs by an isotropic (1 − 1/d) σ|∇c| I, which leaves the
jump across the interface unchanged but needs a pressure below the surrounding fluid's inside
the interface band, which the solver's clamp p >= 0 cannot give. L,
the integral of |∇c| across a flat interface on the rest lattice (:func:`gradient_integral`;
1 in the continuum, 1.012 in 2-D and 1.020 in 3-D at h = 4r), makes the discrete tension σ.

Measured: on a drop cut from the rest lattice the force integrates to 0.99 σκ per area and
its pressure (least squares, the solver's operators) jumps by 0.93 σ/R (2-D, R = 5
spacings). Moving, the jump is only about half of Young-Laplace without gravity: the band's
tangential tension σ|∇c| (≈ σ/(2h)) exceeds the solver's pressure there (p >= 0, its
level set by the clamp), so the band is in net tension and its particles clump (the SPH
tensile instability, Swegle et al. 1995): like neighbours 0.81 spacings apart, unlike ones
1.07, ∫|∇c| falls to 0.78 and the force to 0.59 σκ. Under a hydrostatic head larger than
σ|∇c| the band stays ordered (force 0.94-0.95 σκ). Hu & Adams (2006) and Adami et al.
(2010) add a background pressure for this: ``SPHConfig.background_pressure`` = σ/h (the
band's peak tension σ|∇c| on the lattice, closed scenes only) keeps the band ordered (force
0.86-0.94 σκ), but the reported jump is then 0.79-0.83 σ/R and falls as p_b grows, and the
3-D quick drop is not round in 1.5 s (docs/sph.md, "Background pressure").

**"pairwise": a repulsion between unlike particles** (pairwise-force SPH, Tartakovsky &
Meakin 2005; Tartakovsky & Panchenko 2016, J. Comput. Phys. 305) of the pair potential
u_ab = k_ab φ(r), φ(r) = -∫_r^h w(s/h) ds <= 0 (w: the cubic spline scaled to w(0) = 1),
with k_ab from the Kirkwood-Buff relation σ_ab = k_ab S (S: :func:`lattice_across_sum`,
the sum of φ over the rest-lattice pairs straddling a plane per area). The cocktail's
model (its shipped datasets are made with it; "curvature"
stirs its layers, docs/sph.md): it separates an emulsion but does not give the Laplace
pressure: it opens an empty row between the phases (unlike neighbours 2 spacings apart,
like ones squeezed to 0.8) and its force is carried as pressure by both sides alike
(Δp = 0.13-0.28 of Young-Laplace, docs/sph.md). At walls the fluid's neighbourhood is
mirrored into the wall (:func:`pairwise_wall_images`): a contact angle of
90°, as the other models have; without the images the wall is a hole in the repulsion and
unlike neighbours press a particle into it (the cocktail's oil at the glass: 3-D 2.6 %
without, 0.25 % with them, docs/sph.md, "Walls for the pairwise tension").

Checked against the Young-Laplace jump of a 2-D and a 3-D droplet
(``dcdc validate-sph --case laplace``; ``benchmarks/laplace_curvature.py`` for refinement,
σ and density ratio).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numba as nb
import numpy as np

from ..errors import DcdcError
from .kernels import cubic_values, sigma, w_of_r
from .volume_map import half_space_profile, wall_offset

MODELS = ("pairwise", "csf", "curvature")
# the continuum models: normalised by the lattice's ∫|∇c| (:func:`gradient_integral`) and
# bounded by Brackbill et al.'s capillary time step (:func:`stable_dt`)
CSF_MODELS = ("csf", "curvature")
# |∇c| h above which a particle is in the interface band of "curvature" (Morris 2000,
# "Simulating surface tension with smoothed particle hydrodynamics", Int. J. Numer. Meth.
# Fluids 33, §3: 0.01/h)
BAND_THRESHOLD = 0.01


# ---------------------------------------------------------------------------- coefficients
def _phase_index(names: list, name: str, setting: str, key: str) -> int:
    """Index of phase ``name`` in ``names``; a one-line error naming the setting's ``key``
    when the scene has no such phase."""
    if name not in names:
        raise DcdcError(f"sph.{setting}: {key!r} names no phase {name!r} "
                        f"(phases: {', '.join(names)})")
    return names.index(name)


def _names(phases) -> list:
    """Phase names from :class:`~dcdc.particles.Phase` objects or names."""
    return [p if isinstance(p, str) else p.name for p in phases]


def tension_matrix(tensions: dict, phases) -> np.ndarray | None:
    """The symmetric matrix σ_ab [N/m] (None when no pair has a tension) from ``tensions``:
    a mapping "a/b" (phase names) -> σ_ab; ``phases``: the phases or their names, in order."""
    if not tensions:
        return None
    names = _names(phases)
    out = np.zeros((len(names), len(names)))
    for key, value in tensions.items():
        parts = str(key).split("/")
        if len(parts) != 2 or parts[0] == parts[1]:
            raise DcdcError(f"sph.interfacial_tension: key {key!r} must name two different "
                            "phases as \"a/b\"")
        a, b = (_phase_index(names, p, "interfacial_tension", key) for p in parts)
        out[a, b] = out[b, a] = float(value)
    return out


def _lattice_rows(radius: float, h: float, dim: int):
    """Offsets of a half lattice row (the tangential grid) and the row indices needed to
    cover the support ``h`` on both sides of a plane between two rows."""
    s = 2.0 * radius
    m = int(math.ceil(h / s)) + 1
    tang = np.arange(-m, m + 1) * s
    T = np.stack(np.meshgrid(*([tang] * (dim - 1)), indexing="ij"), axis=-1).reshape(-1, dim - 1)
    return s, m, T


def gradient_integral(radius: float, h: float, dim: int, V0: float) -> float:
    """L = ∫ |∇c| dn across a flat interface on the rest lattice: the rows on both sides,
    each with |∇c_i| = V0 |Σ_{j across} G_ij|, summed times the row spacing 2r (1 in the
    continuum; 1.012 in 2-D, 1.020 in 3-D at h = 4r)."""
    s, m, T = _lattice_rows(radius, h, dim)
    total = 0.0
    for k in range(m):          # row above the plane at radius + s k
        for l in range(m):      # row below at -(radius + s l)
            dy = s * (k + l + 1)
            r = np.sqrt((T ** 2).sum(1) + dy * dy)
            dW = cubic_values(r, h, dim)[1]
            total += float(-(dW / r * dy).sum())
    return 2.0 * s * V0 * total  # both sides alike


def _potential(h: float, n: int = 4001) -> tuple[np.ndarray, np.ndarray]:
    """φ(r) = -∫_r^h w(s/h) ds tabulated at ``n`` points of [0, h] (trapezoidal rule), with
    w the cubic spline scaled to w(0) = 1 (:func:`dcdc.sph.kernels.cubic_values` / σ)."""
    r = np.linspace(0.0, h, n)
    w = cubic_values(r, h, 3)[0] / sigma(h, 3)
    seg = 0.5 * (w[1:] + w[:-1]) * np.diff(r)
    return r, -np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])


def across_integral(h: float, dim: int) -> float:
    """"pairwise": I = π ∫_0^h φ r³ dr (3-D), 2 ∫_0^h φ r² dr (2-D), the continuum
    counterpart of S / n² (Kirkwood & Buff 1949); I < 0."""
    r, phi = _potential(h)
    if dim == 3:
        return float(math.pi * np.trapezoid(phi * r ** 3, r))
    return float(2.0 * np.trapezoid(phi * r ** 2, r))


def lattice_across_sum(radius: float, h: float, dim: int) -> float:
    """"pairwise": S = (1/A) Σ_{i above, j below} φ(|x_i - x_j|) over the rest lattice cut
    by a plane between two rows (≈ 0.52 n² I at h = 4r: the close pairs that dominate the
    continuous integral do not exist on the lattice). S < 0."""
    s, m, T = _lattice_rows(radius, h, dim)
    r, phi = _potential(h)
    total = 0.0
    for k in range(m):
        for l in range(m):
            dist = np.sqrt((T ** 2).sum(1) + (s * (k + l + 1)) ** 2)
            total += float(np.interp(dist, r, phi, right=0.0).sum())
    return total / s ** (dim - 1)


def check_wall_tension(model: str, tensions: dict, wall_tensions: dict | None) -> None:
    """Wall tensions set a contact angle only in the "pairwise" model and against a tension
    between phases: a one-line error otherwise."""
    if wall_tensions and (not tensions or model != "pairwise"):
        raise DcdcError("sph.wall_tension needs sph.interfacial_tension and "
                        "sph.interfacial_model = \"pairwise\" (the other models meet walls "
                        "at 90°)")


def wall_tension_vector(wall_tensions: dict, phases) -> np.ndarray:
    """σ_wk [N/m] per phase from ``wall_tensions`` (phase name -> σ_wk; unnamed phases 0),
    less its smallest value: only differences enter Young's law (:func:`coefficients`);
    ``phases``: the phases or their names, in order."""
    names = _names(phases)
    out = np.zeros(len(names))
    for key, value in wall_tensions.items():
        out[_phase_index(names, key, "wall_tension", key)] = float(value)
    return out - out.min()


def coefficients(model: str, tensions: dict, phases, h: float, V0: float,
                 dim: int, wall_tensions: dict | None = None) -> np.ndarray | None:
    """The matrix the force kernel of ``model`` takes (None without tensions): "csf" and
    "curvature" σ_ab / L [N/m], "pairwise" k_ab = σ_ab / S [N] (< 0, a repulsion) with one
    more row and column, the walls' k_wa = 2 σ_wa / S (:func:`pairwise_wall_images`).

    ``wall_tensions`` (phase -> σ_wa, "pairwise" only) set the contact angle at the walls by
    Young's law: a drop of b in a meets the wall at cos θ_b = (σ_wa − σ_wb) / σ_ab; none:
    90° for every pair."""
    if model not in MODELS:
        raise DcdcError(f"sph.interfacial_model must be one of {', '.join(MODELS)} (got {model!r})")
    check_wall_tension(model, tensions, wall_tensions)
    sig = tension_matrix(tensions, phases)
    if sig is None:
        return None
    radius = V0 ** (1.0 / dim) / 2.0
    if model in CSF_MODELS:
        return sig / gradient_integral(radius, h, dim, V0)
    n = len(phases)
    full = np.zeros((n + 1, n + 1))
    full[:n, :n] = sig
    # 2σ_wa: the mirrored system (fluid + images) holds the mirror plane's tension once for
    # both halves, so each half carries half of the pair coefficient's (pairwise_wall_images)
    full[:n, n] = full[n, :n] = 2.0 * wall_tension_vector(wall_tensions or {}, phases)
    return full / lattice_across_sum(radius, h, dim)


def pair_coefficients(tensions: dict, phases, h: float, V0: float, dim: int,
                      wall_tensions: dict | None = None) -> np.ndarray | None:
    """"pairwise": the matrix k_ab [N], the walls' last (:func:`coefficients`)."""
    return coefficients("pairwise", tensions, phases, h, V0, dim, wall_tensions)


def stable_dt(tensions: dict, phases, spacing: float) -> float:
    """Capillary time-step bound of Brackbill et al. (1992, eq. 64),
    Δt < sqrt(ρ̄ Δx³ / (2π σ)), with ρ̄ the mean rest density of the pair and Δx = 2r;
    inf without tensions."""
    sig = tension_matrix(tensions, phases)
    if sig is None:
        return math.inf
    rho = np.array([p.density for p in phases])
    a, b = np.nonzero(sig > 0)
    if len(a) == 0:
        return math.inf
    return float(np.sqrt(0.5 * (rho[a] + rho[b]) * spacing ** 3 / (2 * math.pi * sig[a, b])).min())


# ---------------------------------------------------------------------------- "csf" kernels
@nb.njit(cache=True, parallel=True)
def capillary_stress(phase, C, rs, idx, G, V0):
    """Π_i [n, d, d] of the module doc: Σ over the phases k ≠ phase_i with C[a, k] > 0 of
    C[a, k] (|g| I − g⊗g/|g|), g = ∇c^k_i = V0 Σ_{j of phase k} G_ij (c^k_i = 0)."""
    n = len(rs) - 1
    d = G.shape[1]
    P = C.shape[0]
    out = np.zeros((n, d, d))
    for i in nb.prange(n):
        a = phase[i]
        g = np.zeros((P, d))
        for e in range(rs[i], rs[i + 1]):
            k = phase[idx[e]]
            if k != a and C[a, k] > 0.0:
                for c in range(d):
                    g[k, c] += G[e, c]
        for k in range(P):
            if k == a or C[a, k] == 0.0:
                continue
            n2 = 0.0
            for c in range(d):
                n2 += g[k, c] * g[k, c]
            if n2 == 0.0:
                continue
            norm = V0 * math.sqrt(n2)
            f = C[a, k]
            for c in range(d):
                out[i, c, c] += f * norm
                for e2 in range(d):
                    out[i, c, e2] -= f * norm * g[k, c] * g[k, e2] / n2
    return out


@nb.njit(cache=True, parallel=True)
def stress_acceleration(Pi, rho0, rs, idx, G, Sb, V0):
    """a_i = (1/ρ0_i) [V0 Σ_j (Π_i + Π_j)·G_ij + Π_i·S_b,i] (the pressure operator with
    −p I -> Π): antisymmetric pairs, momentum conserving."""
    n, d, _ = Pi.shape
    out = np.zeros((n, d))
    for i in nb.prange(n):
        for e in range(rs[i], rs[i + 1]):
            j = idx[e]
            for c in range(d):
                s = 0.0
                for k in range(d):
                    s += (Pi[i, c, k] + Pi[j, c, k]) * G[e, k]
                out[i, c] += V0 * s
        for c in range(d):
            s = 0.0
            for k in range(d):
                s += Pi[i, c, k] * Sb[i, k]
            out[i, c] = (out[i, c] + s) / rho0[i]
    return out


def csf_acceleration(phase, rho0, C, rs, idx, G, Sb, V0):
    """"csf": the capillary acceleration of every particle (module doc)."""
    return stress_acceleration(capillary_stress(phase, C, rs, idx, G, V0), rho0, rs, idx, G,
                               Sb, V0)


# ---------------------------------------------------------------------------- "curvature" kernels
@nb.njit(cache=True, parallel=True)
def colour_gradient(phase, a, b, rs, idx, G, V0):
    """∇c_i = V0 Σ_j (c_j − c_i) G_ij of the pair's colour c = 1 on phase ``a``, 0 on phase
    ``b`` (particles of other phases are left out of the sums and get 0): it points into
    ``a`` from both sides of the interface and is zero away from it."""
    n = len(rs) - 1
    d = G.shape[1]
    out = np.zeros((n, d))
    for i in nb.prange(n):
        pi = phase[i]
        if pi != a and pi != b:
            continue
        ci = 1.0 if pi == a else 0.0
        for e in range(rs[i], rs[i + 1]):
            pj = phase[idx[e]]
            if pj != a and pj != b:
                continue
            dc = (1.0 if pj == a else 0.0) - ci
            if dc != 0.0:
                for c in range(d):
                    out[i, c] += V0 * dc * G[e, c]
    return out


@nb.njit(cache=True, parallel=True)
def curvature(grad, norm, x, rs, idx, G, threshold, kappa_max):
    """κ_i = −∇·n̂_i (n̂ = ∇c/|∇c|, ``norm`` = |∇c|) from the kernel-gradient-corrected SPH
    gradient (Bonet & Lok 1999): ∇n̂_i = D_i M_i⁻¹ with D_i = Σ_j (n̂_j − n̂_i) ⊗ G_ij and
    M_i = Σ_j (x_j − x_i) ⊗ G_ij, both sums over the neighbours whose |∇c| exceeds
    ``threshold`` (the interface band), so that it is exact for a linear normal field however
    lopsided the band's truncated support, bounded by ``kappa_max``. Adami, Hu & Adams
    (2010, eq. 21) normalise the same sums by the trace of M only (their reproducing
    divergence, exact where the band's neighbours are isotropic); in a band two rows wide on
    either side that reads 17 % high on a lattice disc (R = 10 spacings), the full
    correction 4 %. 0 outside the band or where its neighbours do not span every direction
    (det M < 0.1 (tr M / d)^d)."""
    n, d = grad.shape
    out = np.zeros(n)
    for i in nb.prange(n):
        gi = norm[i]
        if gi <= threshold:
            continue
        M = np.zeros((d, d))
        D = np.zeros((d, d))
        for e in range(rs[i], rs[i + 1]):
            j = idx[e]
            gj = norm[j]
            if gj <= threshold:
                continue
            for a in range(d):
                for b in range(d):
                    M[a, b] += (x[j, a] - x[i, a]) * G[e, b]
                    D[a, b] += (grad[j, a] / gj - grad[i, a] / gi) * G[e, b]
        trM = 0.0
        for c in range(d):
            trM += M[c, c]
        # a band support that does not span every direction (det ≪ (tr/d)^d; ~1 for a
        # full one) gives no divergence
        if abs(np.linalg.det(M)) < 0.1 * abs(trM / d) ** d:
            continue
        A = D @ np.linalg.inv(M)
        tr = 0.0
        for c in range(d):
            tr += A[c, c]
        # no interface is more curved than a single particle's: |κ| <= (d − 1)/r
        out[i] = max(-kappa_max, min(kappa_max, -tr))
    return out


@nb.njit(cache=True, parallel=True)
def band_average(kappa, norm, rs, idx, W):
    """κ̄_i = Σ_j W_ij |∇c_j| κ_j / Σ_j W_ij |∇c_j| (``norm`` = |∇c|) over the band
    neighbours, those with κ ≠ 0 (self included): the curvature smoothed along the band,
    weighted towards its middle rows, whose normals are least disturbed when the particles
    disorder (parasitic currents are driven by the curvature's particle-scale noise)."""
    n = len(kappa)
    out = np.zeros(n)
    for i in nb.prange(n):
        if kappa[i] == 0.0:
            continue
        num = 0.0
        den = 0.0
        for e in range(rs[i], rs[i + 1]):
            j = idx[e]
            if kappa[j] == 0.0:
                continue
            w = W[e] * norm[j]
            num += w * kappa[j]
            den += w
        out[i] = num / den if den > 0.0 else kappa[i]
    return out


def wall_contact(grad, Sb, h):
    """A contact angle of 90° (Brackbill et al. 1992, "wall adhesion": n̂ = n̂_w cos θ +
    t̂_w sin θ at a wall) where an interface meets a wall: within a support of a wall
    (|S_b| h > 0.01, S_b = ∇Ψ_b the walls' kernel gradient, along the wall normal) a colour
    gradient that is within 30° of the wall's plane (|n̂·ŝ| < ½) loses its wall-normal part.
    The difference-form sum misses the colour inside the wall, so next to a wall it tilts:
    on a flat interface at rest by 10° at the tank's edges, where the curvature estimated
    from it reached κh = 0.5 (3-D) and drove a two-layer tank at rest to 0.56 m/s (0.07
    without tension). An interface facing the wall (a drop near it) keeps its normal."""
    s2 = (Sb * Sb).sum(1)
    g2 = (grad * grad).sum(1)
    gs = (grad * Sb).sum(1)
    meet = (s2 * h * h > BAND_THRESHOLD ** 2) & (g2 > 0) & (gs * gs < 0.25 * g2 * s2)
    if not meet.any():
        return grad
    out = grad.copy()
    out[meet] -= (gs[meet] / s2[meet])[:, None] * Sb[meet]
    return out


def pair_curvature(x, phase, a, b, rs, idx, G, W, Sb, V0, h):
    """The colour gradient ∇c of the pair (a, b) (:func:`colour_gradient`, the walls' contact
    angle by :func:`wall_contact`) and the band's smoothed curvature κ̄ (:func:`curvature`
    over |∇c| > :data:`BAND_THRESHOLD`/h, bounded by a single particle's (d − 1)/r, then
    :func:`band_average`)."""
    radius = 0.5 * V0 ** (1.0 / x.shape[1])  # the particle radius r (V0 ≈ (2r)^d)
    grad = wall_contact(colour_gradient(phase, a, b, rs, idx, G, V0), Sb, h)
    norm = np.sqrt((grad * grad).sum(1))
    kappa = curvature(grad, norm, x, rs, idx, G, BAND_THRESHOLD / h, (x.shape[1] - 1) / radius)
    return grad, band_average(kappa, norm, rs, idx, W)


def curvature_acceleration(x, phase, rho0, C, rs, idx, G, W, Sb, V0, h):
    """"curvature": the continuum surface force of Brackbill, Kothe & Zemach (1992) per phase
    pair (a, b) with σ_ab > 0 (``C`` = σ_ab / L, :func:`coefficients`), f_i = σ κ̄_i ∇c_i
    per volume, i.e.

        a_i = (σ_ab / L) κ̄_i ∇c_i / ρ0_i.

    Per volume, like the solver's pressure force, so that the pressure step that balances it
    does not depend on the densities. Brackbill et al.'s density-scaled variant (their
    eq. 43, f ρ_i/ρ̄, the same acceleration on both sides) leaves the light side of a heavy
    drop too little force against the drop's pressure, which the symmetric pressure force
    passes to it divided by its own small density: an empty row opens between the phases
    and the jump falls to 0.43 (2-D, drop 1000 in 100; docs/sph.md). ∇c and κ̄:
    :func:`pair_curvature`. Not pairwise antisymmetric: the net force on a closed drop is
    zero only as far as the discrete ∮ κ n̂ dA is."""
    out = np.zeros_like(x)
    P = C.shape[0]
    for a in range(P):
        for b in range(a + 1, P):
            if C[a, b] > 0.0:
                grad, kappa = pair_curvature(x, phase, a, b, rs, idx, G, W, Sb, V0, h)
                out += (C[a, b] * kappa / rho0)[:, None] * grad
    return out


# ---------------------------------------------------------------------------- "pairwise" kernel
@nb.njit(cache=True, parallel=True)
def pairwise_acceleration(x, phase, rho0, K, rs, idx, h, V0):
    """"pairwise": a repulsion of the pair potential u_ab(r) = k_ab φ(r), k_ab <= 0, between
    particles of phases a != b,
        a_i = (1 / (ρ0_i V0)) Σ_{j: phase_j != phase_i} k_ab w(|x_ij| / h) (x_j - x_i)/|x_ij|
    with w the cubic spline shape scaled to w(0) = 1. Pairwise and antisymmetric: momentum
    is conserved and the force derives from a potential (no energy is created)."""
    n, d = x.shape
    out = np.zeros((n, d))
    for i in nb.prange(n):
        pi = phase[i]
        m = rho0[i] * V0
        for e in range(rs[i], rs[i + 1]):
            j = idx[e]
            pj = phase[j]
            if pj == pi:
                continue
            k = K[pi, pj]
            if k == 0.0:
                continue
            r2 = 0.0
            for a in range(d):
                t = x[j, a] - x[i, a]
                r2 += t * t
            r = math.sqrt(r2)
            if r < 1e-9 * h or r >= h:
                continue
            f = k * w_of_r(r, h, 1.0) / (m * r)  # the spline's shape, w(0) = 1
            for a in range(d):
                out[i, a] += f * (x[j, a] - x[i, a])
    return out


@nb.njit(cache=True, parallel=True)
def pairwise_wall_images(x, phase, rho0, K, rs, idx, psi_wall, Sb, V0, h, psi_table, z_table):
    """The walls' part of "pairwise": the method of images. Where the wall cuts a particle's
    support, the fluid's neighbourhood is reflected across the wall's local plane and the
    reflected unlike neighbours j' repel i like real ones,

        a_i += (1 / (ρ0_i V0)) Σ_{j: phase_j != phase_i} k_ab w(|x_j' - x_i| / h) (x_j' - x_i)/|x_j' - x_i|,
        x_j' - x_i = y - 2 (y·n̂ + z_i) n̂,   y = x_j - x_i,

    with n̂ = -S_b/|S_b| the wall normal into the fluid (S_b = ∇Ψ_b, the walls' kernel
    gradient) and z_i the distance from the wall's surface, read from the walls' share of ψ
    (``psi_wall``, Ψ_b) on the flat half-space's profile (:func:`wall_image_table`:
    ``psi_table`` increasing, ``z_table`` the matching distances). Mirror symmetry across the
    wall is a contact angle of 90°, as :func:`wall_contact` gives the "curvature" model: an interface meeting the wall at right
    angles feels no force along the wall normal, and a particle at the wall under unlike
    fluid is no longer pressed into it by the neighbours on its fluid side alone (without the
    images the wall is a hole in the repulsion, so unlike neighbours push the particle into
    it; docs/sph.md, "Walls for the pairwise tension"). Only the nearest wall's plane is
    reflected (a corner gets one of its two walls), z is exact for flat walls of the plain
    volume map (on curved walls, wall particles or a balanced wall it is approximate), and
    the images' reaction goes to the wall.

    Wetting (``K``'s last row, the walls' k_wa = 2 σ_wa / S, :func:`coefficients`): the
    images are also the wall's own material w, so every image j' (i's own included) repels i
    with k_wa besides (a of phase_i). The fluid and its images form a mirror-symmetric system
    in which the mirror plane is an interface of tension k_wa S (the Kirkwood-Buff sum S of
    the rest lattice, which the images continue) shared by both halves: the fluid's half
    carries k_wa S / 2 = σ_wa, and a drop of b in a meets the wall at Young's angle
    cos θ_b = (σ_wa − σ_wb) / σ_ab in equilibrium. Measured (docs/sph.md, "Wetting"): a 2-D
    drop receding from 90° settles there (119° for 120°); the hysteresis is large (from
    150° it stays at 138° for 90°) and 3-D drops fall short (104° for 120°)."""
    n, d = x.shape
    out = np.zeros((n, d))
    for i in nb.prange(n):
        s2 = 0.0
        for a in range(d):
            s2 += Sb[i, a] * Sb[i, a]
        if s2 * h * h <= BAND_THRESHOLD * BAND_THRESHOLD:
            continue
        psi_b = psi_wall[i]
        if psi_b <= 1e-4:
            continue
        z = np.interp(psi_b, psi_table, z_table)
        sn = math.sqrt(s2)  # n̂ = -S_b / sn
        pi = phase[i]
        m = rho0[i] * V0
        kw = K[pi, K.shape[0] - 1]  # the wall's material against phase_i
        for e in range(rs[i], rs[i + 1]):
            j = idx[e]
            k = K[pi, phase[j]] + kw
            if k == 0.0:
                continue
            zeta = 0.0  # y·n̂
            for a in range(d):
                zeta -= (x[j, a] - x[i, a]) * Sb[i, a] / sn
            shift = 2.0 * (zeta + z) / sn  # x_j' - x_i = y + shift S_b (scalar loops: no
            r2 = 0.0                       # small arrays allocated per pair in the hot path)
            for a in range(d):
                t = x[j, a] - x[i, a] + shift * Sb[i, a]
                r2 += t * t
            r = math.sqrt(r2)
            if r < 1e-9 * h or r >= h:
                continue
            f = k * w_of_r(r, h, 1.0) / (m * r)
            for a in range(d):
                out[i, a] += f * (x[j, a] - x[i, a] + shift * Sb[i, a])
    return out


@lru_cache(maxsize=8)
def wall_image_table(h: float, dim: int, V0: float) -> tuple[np.ndarray, np.ndarray]:
    """(Ψ increasing, z) for :func:`pairwise_wall_images`: the distance z from the walls'
    surface of a point whose walls' share of ψ is Ψ, on the flat half-space's profile
    (:func:`dcdc.sph.volume_map.half_space_profile`) less the volume map's offset
    (:func:`dcdc.sph.volume_map.wall_offset`: the map's solid lies that far behind the
    surface, so that the rest lattice touching a wall has ψ = 1). The mirror plane is thus
    the walls' surface, half a spacing beyond the rest lattice's first row, and the images of
    that lattice continue it."""
    radius = 0.5 * V0 ** (1.0 / dim)
    z, psi = half_space_profile(h, dim)
    z = z - wall_offset(radius, h, dim, V0)
    return np.ascontiguousarray(psi[::-1]), np.ascontiguousarray(z[::-1])
