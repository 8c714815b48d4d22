"""Interfacial tension between phase pairs (docs/sph.md, "Interfacial tension").

``interfacial_tension = {"a/b" = σ_ab}`` [N/m; per unit depth in 2-D] with one of two models
(``SPHConfig.interfacial_model``):

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
3-D quick drop is not round in 1.5 s (docs/sph.md, "Background pressure"), so "csf" is
not the default.

**"pairwise": a repulsion between unlike particles** (pairwise-force SPH, Tartakovsky &
Meakin 2005; Tartakovsky & Panchenko 2016, J. Comput. Phys. 305) of the pair potential
u_ab = k_ab φ(r), φ(r) = -∫_r^h w(s/h) ds <= 0 (w: the cubic spline scaled to w(0) = 1),
with k_ab from the Kirkwood-Buff relation σ_ab = k_ab S (S: :func:`lattice_across_sum`,
the sum of φ over the rest-lattice pairs straddling a plane per area). The default (the
shipped cocktail datasets were made with it): it separates an emulsion but does not give the Laplace pressure: it opens an empty row
between the phases (unlike neighbours 2 spacings apart, like ones squeezed to 0.8) and its
force is carried as pressure by both sides alike (Δp = 0.14-0.26 of Young-Laplace, docs/sph.md).

Checked against the Young-Laplace jump of a 2-D and a 3-D droplet
(``dcdc validate-sph --case laplace``).
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..errors import DcdcError
from .kernels import cubic_values, sigma, w_of_r

MODELS = ("pairwise", "csf")


# ---------------------------------------------------------------------------- coefficients
def tension_matrix(tensions: dict, phases) -> np.ndarray | None:
    """The symmetric matrix σ_ab [N/m] (None when no pair has a tension) from ``tensions``:
    a mapping "a/b" (phase names) -> σ_ab."""
    if not tensions:
        return None
    names = [p.name for p in phases]
    out = np.zeros((len(names), len(names)))
    for key, value in tensions.items():
        parts = str(key).split("/")
        if len(parts) != 2 or parts[0] == parts[1]:
            raise DcdcError(f"sph.interfacial_tension: key {key!r} must name two different "
                            "phases as \"a/b\"")
        for p in parts:
            if p not in names:
                raise DcdcError(f"sph.interfacial_tension: {key!r} names no phase {p!r} "
                                f"(phases: {', '.join(names)})")
        a, b = names.index(parts[0]), names.index(parts[1])
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


def coefficients(model: str, tensions: dict, phases, h: float, V0: float,
                 dim: int) -> np.ndarray | None:
    """The matrix the force kernel of ``model`` takes (None without tensions): "csf" σ_ab / L
    [N/m], "pairwise" k_ab = σ_ab / S [N] (< 0, a repulsion)."""
    if model not in MODELS:
        raise DcdcError(f"sph.interfacial_model must be one of {', '.join(MODELS)} (got {model!r})")
    sig = tension_matrix(tensions, phases)
    if sig is None:
        return None
    radius = V0 ** (1.0 / dim) / 2.0
    if model == "csf":
        return sig / gradient_integral(radius, h, dim, V0)
    return sig / lattice_across_sum(radius, h, dim)


def pair_coefficients(tensions: dict, phases, h: float, V0: float, dim: int) -> np.ndarray | None:
    """"pairwise": the matrix k_ab [N] (:func:`coefficients`)."""
    return coefficients("pairwise", tensions, phases, h, V0, dim)


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
