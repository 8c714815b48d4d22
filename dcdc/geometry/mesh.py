"""Triangle meshes as walls: loading, signed distance of a closed mesh's solid, shells
behind open surfaces, and their 2-D cross-sections.

Distances come from libigl (``igl.AABB``: an axis-aligned bounding-box tree over the
triangles, closest point in O(log T) per query instead of O(T)); the inside test of a
closed mesh from libigl's fast winding number (``igl.FastWindingNumberBVH``, Barill et
al. 2018; robust to small defects). Both trees are built once per mesh. A side of an open
surface comes from the angle-weighted pseudonormal at the closest point (Bærentzen &
Aanæs 2005): the face normal inside a face, the mean of the two faces' normals on an
edge, the angle-weighted vertex normal at a vertex. ``docs/scenes.md`` ("Meshes") says why
libigl and what it costs.

An SDF here may be *banded*: with ``band = b`` it is exact where the distance to the
surface is at most ``b``; farther away it has the right sign and a magnitude of at least
``b`` (a lower bound of the distance), which is all that sampling walls, checking fluid
against walls and the SPH volume map need. A coarse voxel mask of the surface's
neighbourhood sends far points past the tree, so a band makes points deep inside (or far
outside) a large mesh cost nothing.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import DcdcError

CHUNK = 65_536          # points per tree query (a progress bar appears beyond one chunk)
PROGRESS_POINTS = 300_000  # ... and only for calls with at least this many near points
MASK_CELLS = 4_000_000  # cap on the near-surface voxel mask


# ------------------------------------------------------------------ loading
MAX_COORDINATE = 1e9  # |x| of a vertex in the file (trimesh merges on a 1e-8 grid: int64)


def load_mesh(path, scale=1.0, translate=None):
    """A triangle mesh (OBJ/STL/PLY... via trimesh), scaled then translated.

    Vertices at the same position are merged whatever their normals or texture
    coordinates (an OBJ written with one normal per face, such as DeepLagrangianFluids'
    ``Box.obj``, otherwise reads as separate faces with open edges); degenerate faces
    are dropped, a face and its flipped twin cancel (both go; SPlisHSPlasH's
    ``Dragon_50k.obj`` has 11 such fins), a face repeated with one orientation is kept once,
    and holes of one or two triangles are closed. A closed mesh (:func:`edge_defects`:
    non-manifold edges allowed) is oriented
    outwards (an inward-wound one is flipped: the solid is always the enclosed volume);
    an open one keeps the file's orientation (made consistent where it is not). Open
    meshes are returned as such: :func:`mesh_solid` refuses them, :func:`mesh_shell`
    takes them. ``mesh.metadata`` holds ``dcdc_file``, ``dcdc_closed``,
    ``dcdc_open_edges`` and ``dcdc_flipped`` (faces were inward-wound)."""
    import trimesh

    try:
        # unprocessed: trimesh's processing drops non-finite vertices (and their faces)
        # without a word, which builds another wall than the file describes
        mesh = trimesh.load(str(path), force="mesh", process=False)
    except Exception as e:  # trimesh raises many types for broken files
        raise DcdcError(f"cannot read mesh {path}: {e}") from None
    if not len(getattr(mesh, "faces", [])):
        raise DcdcError(f"mesh {path} has no triangles")
    bad = np.flatnonzero(~np.isfinite(np.asarray(mesh.vertices)).all(axis=1))
    if len(bad):
        raise DcdcError(f"mesh {path}: {len(bad)} vertex(es) with a coordinate that is not a "
                        f"finite number (first: {np.asarray(mesh.vertices)[bad[0]].tolist()})")
    size = float(np.abs(np.asarray(mesh.vertices)).max())
    if size > MAX_COORDINATE:  # merging vertices rounds them to integers of 1e-8
        raise DcdcError(f"mesh {path}: coordinates reach {size:.3g}, beyond the "
                        f"{MAX_COORDINATE:.0e} it can be read with; store it in smaller units "
                        f"and place it with scale")
    mesh.process()
    mesh = mesh.copy()
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    mesh.update_faces(_kept_faces(np.asarray(mesh.faces)) & mesh.nondegenerate_faces())
    mesh.remove_unreferenced_vertices()
    if not len(mesh.faces):
        raise DcdcError(f"mesh {path} has no triangles of non-zero area")
    if edge_defects(mesh)[0]:
        trimesh.repair.fill_holes(mesh)  # a missing triangle or two; larger holes stay open
    odd, unbalanced = edge_defects(mesh)
    if not odd and unbalanced:
        trimesh.repair.fix_winding(mesh)  # closed, but some faces wound the other way
        odd, unbalanced = edge_defects(mesh)
    closed = not odd and not unbalanced
    flipped = False
    if closed and mesh.volume < 0:
        mesh.invert()
        flipped = True
    elif not closed and not mesh.is_winding_consistent:
        before = mesh.face_normals.copy()
        trimesh.repair.fix_winding(mesh)
        if (np.einsum("ij,ij->i", before, mesh.face_normals) * mesh.area_faces).sum() < 0:
            mesh.invert()  # keep the orientation most of the file's area had
    mesh.apply_scale(scale)
    if translate is not None:
        mesh.apply_translation(np.asarray(translate, dtype=np.float64))
    mesh.metadata.update(dcdc_file=str(path), dcdc_closed=closed, dcdc_open_edges=odd,
                         dcdc_flipped=flipped)
    return mesh


def _kept_faces(F: np.ndarray) -> np.ndarray:
    """Mask of the faces to keep among duplicates (same three vertices): a face and its
    flipped twin cancel (a zero-thickness fin, as in SPlisHSPlasH's Dragon_50k.obj) and
    both go; of faces repeated with one orientation, one stays."""
    keep = np.ones(len(F), dtype=bool)
    key = np.sort(F, axis=1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    r = np.argmin(F, axis=1)
    rot = F[np.arange(len(F))[:, None], (r[:, None] + np.arange(3)) % 3]
    even = rot[:, 1] < rot[:, 2]  # the same cyclic order as the sorted triple
    for g in np.flatnonzero(cnt > 1):
        idx = np.flatnonzero(inv == g)
        keep[idx] = False
        net = int(even[idx].sum()) - int((~even[idx]).sum())
        pick = idx[even[idx]] if net > 0 else idx[~even[idx]]
        keep[pick[:min(abs(net), 1)]] = True
    return keep


def edge_defects(mesh) -> tuple[int, int]:
    """(open edges: used by an odd number of faces, unbalanced edges: not traversed as
    often in each direction). A surface is closed and consistently wound when both are 0:
    then it bounds a solid (its winding number is 0 or 1 everywhere off the surface), even
    where it is not a manifold (edges shared by 4 faces where two parts touch)."""
    F = np.asarray(mesh.faces, dtype=np.int64)
    d = F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    a, b = d.min(1), d.max(1)
    _, inv, cnt = np.unique(a * (int(F.max()) + 1) + b, return_inverse=True, return_counts=True)
    net = np.bincount(inv.ravel(), weights=np.where(d[:, 0] < d[:, 1], 1.0, -1.0))
    return int((cnt % 2 == 1).sum()), int((net != 0).sum())


def is_closed(mesh) -> bool:
    """Closed and consistently wound (:func:`edge_defects` both 0)."""
    if "dcdc_closed" in mesh.metadata:
        return bool(mesh.metadata["dcdc_closed"])
    return edge_defects(mesh) == (0, 0)


def _name(mesh) -> str:
    return mesh.metadata.get("dcdc_file", "mesh")


def require_closed(mesh, hint: str = ""):
    """:class:`DcdcError` unless ``mesh`` is a closed surface."""
    if not is_closed(mesh):
        odd, unbalanced = edge_defects(mesh)
        what = f"{odd} open edges" if odd else f"{unbalanced} edges wound the same way twice"
        raise DcdcError(f"mesh {_name(mesh)} is not a closed surface ({what}); "
                        f"{hint or 'dcdc needs a closed mesh that encloses the solid'}")


# ------------------------------------------------------------------ 3-D distance
class _NearMask:
    """Voxels within ``reach`` of the surface (conservative): a point outside them is
    farther than ``reach`` from every triangle."""

    def __init__(self, tris: np.ndarray, reach: float):
        from scipy import ndimage
        lo, hi = tris.min((0, 1)) - reach, tris.max((0, 1)) + reach
        ext = hi - lo
        g = max(reach / 2, float(np.prod(ext) / MASK_CELLS) ** (1 / 3), 1e-12)
        self.lo, self.g = lo, g
        self.shape = tuple(int(n) for n in np.floor(ext / g) + 1)
        mask = np.zeros(self.shape, dtype=bool)
        for pts in _surface_samples(tris, g):
            idx = np.floor((pts - lo) / g).astype(np.int64)
            np.clip(idx, 0, np.array(self.shape) - 1, out=idx)
            mask[tuple(idx.T)] = True
        k = int(math.ceil(reach / g)) + 2
        self.mask = ndimage.maximum_filter(mask.view(np.uint8), size=2 * k + 1).astype(bool)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        idx = np.floor((x - self.lo) / self.g).astype(np.int64)
        ok = ((idx >= 0) & (idx < np.array(self.shape))).all(1)
        out = np.zeros(len(x), dtype=bool)
        out[ok] = self.mask[tuple(idx[ok].T)]
        return out


def _surface_samples(tris: np.ndarray, g: float):
    """Points on the triangles, every surface point within ``g`` of one (barycentric grids
    of n = ceil(longest edge / g) steps), yielded in groups of equal n."""
    edges = np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=2).max(1)
    n = np.maximum(np.ceil(edges / g), 1).astype(np.int64)
    for m in np.unique(n):
        t = tris[n == m]
        i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1), indexing="ij")
        keep = i + j <= m
        a, b = i[keep] / m, j[keep] / m                    # [S]
        for s in range(0, len(t), max(1, 2_000_000 // len(a))):
            tt = t[s:s + max(1, 2_000_000 // len(a))]
            p = (tt[:, None, 0] * (1 - a - b)[None, :, None] + tt[:, None, 1] * a[None, :, None]
                 + tt[:, None, 2] * b[None, :, None])
            yield p.reshape(-1, 3)


class MeshDistance:
    """Distance to a triangle mesh and the side of a query point, with trees built once.

    ``inside(x)``: fast winding number > 1/2 (closed meshes). ``closest(x)``: distance,
    closest point and triangle. ``side(x, c, i)``: +1 in front of the surface (the side
    its normals point to), -1 behind it, by the pseudonormal at the closest point."""

    def __init__(self, mesh):
        import igl
        self.V = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
        self.F = np.ascontiguousarray(mesh.faces, dtype=np.int64)
        self.tris = self.V[self.F]
        self.lo, self.hi = self.tris.min((0, 1)), self.tris.max((0, 1))
        self.n_faces = len(self.F)
        self.tree = igl.AABB()
        self.tree.init(self.V, self.F)
        self._mesh = mesh
        self._fwn = None
        self._normals = None
        self._masks = {}

    def inside(self, x: np.ndarray) -> np.ndarray:
        import igl
        if self._fwn is None:
            self._fwn = igl.FastWindingNumberBVH()
            self._fwn.init(self.V, self.F)
        return np.asarray(self._fwn.winding_number(np.ascontiguousarray(x, dtype=np.float64))) > 0.5

    def closest(self, x: np.ndarray, progress: str | None = None):
        """(distance [N], closest points [N, 3], triangle index [N]) by the AABB tree, in
        chunks (a tqdm bar on a terminal for large calls)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        d = np.empty(len(x))
        c = np.empty((len(x), 3))
        idx = np.empty(len(x), dtype=np.int64)
        starts = range(0, len(x), CHUNK)
        bar = None
        if progress and len(x) >= PROGRESS_POINTS:
            from tqdm import tqdm
            bar = tqdm(total=len(x), desc=f"{progress} ({self.n_faces} triangles)", unit="pt",
                       unit_scale=True, leave=False, disable=None)
        for s in starts:
            sq, i, cp = self.tree.squared_distance(self.V, self.F, x[s:s + CHUNK])
            d[s:s + CHUNK] = np.sqrt(np.maximum(sq, 0.0))
            c[s:s + CHUNK] = cp
            idx[s:s + CHUNK] = i
            if bar is not None:
                bar.update(len(i))
        if bar is not None:
            bar.close()
        return d, c, idx

    def near(self, x: np.ndarray, reach: float) -> np.ndarray:
        """Conservative: False only where the point is farther than ``reach``."""
        key = float(reach)
        if key not in self._masks:
            self._masks[key] = _NearMask(self.tris, key)
        return self._masks[key](x)

    def _pseudonormals(self):
        if self._normals is None:
            m = self._mesh
            fn = np.asarray(m.face_normals, dtype=np.float64)
            fue = np.asarray(m.faces_unique_edges)
            en = np.zeros((len(m.edges_unique), 3))
            np.add.at(en, fue.ravel(), np.repeat(fn, 3, axis=0))
            vn = np.zeros((len(self.V), 3))
            np.add.at(vn, self.F.ravel(), (fn[:, None, :] * m.face_angles[:, :, None]).reshape(-1, 3))
            unit = (lambda a: a / np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-300))
            self._normals = fn, fue, unit(en), unit(vn)
        return self._normals

    def side(self, x: np.ndarray, c: np.ndarray, i: np.ndarray) -> np.ndarray:
        fn = np.asarray(self._mesh.face_normals)
        r = x - c
        dot = np.einsum("ij,ij->i", r, fn[i])
        out = np.where(dot >= 0, 1.0, -1.0)
        # x - c along the face normal: the face's own side (also right where c lies on an
        # edge or corner); otherwise c is on an edge or a corner and its pseudonormal decides
        rest = np.flatnonzero(np.abs(dot) < (1 - 1e-9) * np.sqrt(np.einsum("ij,ij->i", r, r)))
        if len(rest):
            out[rest] = self._pseudo_side(x[rest], c[rest], i[rest])
        return out

    def _pseudo_side(self, x: np.ndarray, c: np.ndarray, i: np.ndarray) -> np.ndarray:
        fn, fue, en, vn = self._pseudonormals()
        t = self.tris[i]
        a, b, cc = t[:, 0], t[:, 1], t[:, 2]
        v0, v1, v2 = b - a, cc - a, c - a
        d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
        d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
        den = np.maximum(d00 * d11 - d01 * d01, 1e-300)
        bv = (d11 * d20 - d01 * d21) / den          # weight of vertex b
        bw = (d00 * d21 - d01 * d20) / den          # weight of vertex c
        bu = 1.0 - bv - bw                          # weight of vertex a
        eps = 1e-7
        zu, zv, zw = bu < eps, bv < eps, bw < eps
        n = fn[i].copy()
        for z, k in ((zw, 0), (zu, 1), (zv, 2)):   # on edge ab, bc, ca
            n[z] = en[fue[i[z], k]]
        for z, k in ((zv & zw, 0), (zu & zw, 1), (zu & zv, 2)):  # at vertex a, b, c
            n[z] = vn[self.F[i[z], k]]
        return np.where(((x - c) * n).sum(1) >= 0, 1.0, -1.0)


def _box_distance(x, lo, hi):
    q = np.abs(x - (lo + hi) / 2) - (hi - lo) / 2
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(1), 0.0)


def _banded(md: MeshDistance, band, near_value, far_value, outside_value, progress):
    """SDF assembled from ``near_value(x, d, c, i)`` (exact, where the tree is asked),
    ``far_value(x, reach)`` (inside the grown bounding box but farther than ``reach`` from
    the surface) and ``outside_value(box_distance, reach)`` (beyond the grown box).
    ``band`` None: the tree is asked everywhere within a quarter of the mesh's size around
    its bounding box."""
    size = float(np.max(md.hi - md.lo))
    reach = 0.25 * size if band is None else float(band)

    def f(x):
        x = np.asarray(x, dtype=np.float64)
        if not len(x):
            return np.zeros(0)
        bd = _box_distance(x, md.lo, md.hi)
        out = outside_value(bd, reach)
        inb = np.flatnonzero(bd <= reach)
        if band is not None and len(inb):
            close = md.near(x[inb], reach)
            rest, inb = inb[~close], inb[close]
            if len(rest):
                out[rest] = far_value(x[rest], reach)
        if len(inb):
            d, c, i = md.closest(x[inb], progress)
            out[inb] = near_value(x[inb], d, c, i)
        return out
    return f


def mesh_solid(mesh, band: float | None = None, progress: str | None = "mesh distance"):
    """SDF of the solid enclosed by a closed triangle mesh (3-D; negative inside): exact
    distance to the triangles (AABB tree), sign from the pseudonormal at the closest point
    (exact for a closed, consistently wound mesh) and, farther than ``band`` from the
    surface, from the fast winding number (the closest point is not computed there). With ``band``
    see the module docstring; without, exact within a quarter of the mesh's size around
    its bounding box and the box distance (a lower bound) beyond."""
    require_closed(mesh)
    md = MeshDistance(mesh)
    f = _banded(md, band,
                lambda x, d, c, i: d * md.side(x, c, i),
                lambda x, reach: np.where(md.inside(x), -reach, reach),
                lambda bd, reach: bd.copy(),
                progress)
    f.mesh_distance = md
    return f


def mesh_shell(mesh, thickness: float, behind: bool = True, band: float | None = None,
               progress: str | None = "mesh distance"):
    """SDF of the shell of ``thickness`` on one side of a surface, open or closed (3-D):
    behind the faces (opposite their normals; inside a closed mesh) or, with
    ``behind=False``, in front. With s the signed distance to the surface (pseudonormal
    side), the shell is -T <= s <= 0 (behind) and its SDF |s + T/2| - T/2; it is rounded
    around an open surface's border. ``band`` as in :func:`mesh_solid` (default: the
    larger of T and a quarter of the mesh's size)."""
    T = float(thickness)
    md = MeshDistance(mesh)
    sgn = 1.0 if behind else -1.0
    if band is None:
        band = max(T, 0.25 * float(np.max(md.hi - md.lo)))

    def near(x, d, c, i):
        s = sgn * d * md.side(x, c, i)
        return np.abs(s + T / 2) - T / 2
    # farther than band + T from the surface: at least band from the shell, outside it
    f = _banded(md, band + T, near, lambda x, reach: np.full(len(x), reach - T),
                lambda bd, reach: np.maximum(bd, reach) - T, progress)
    f.mesh_distance = md
    return f


# ------------------------------------------------------------------ 2-D sections
def _section_segments(mesh, z: float):
    """Segments [n, 2, 2] where the plane at height ``z`` (third coordinate) cuts the
    mesh, each oriented so that its right-hand normal is the cut face's normal, and the
    plane height used (nudged off vertices lying exactly in it)."""
    from trimesh.intersections import mesh_plane
    size = float(np.max(mesh.extents))
    if np.any(np.abs(mesh.vertices[:, 2] - z) < 1e-9 * max(size, 1.0)):
        z += 1e-7 * max(size, 1.0)  # a vertex in the plane makes degenerate cuts
    try:
        lines, faces = mesh_plane(mesh, [0, 0, 1], [0, 0, z], return_faces=True)
    except (ValueError, IndexError):
        lines, faces = np.zeros((0, 2, 3)), np.zeros(0, dtype=np.int64)
    seg = np.asarray(lines, dtype=np.float64)[:, :, :2]
    if not len(seg):
        raise DcdcError(f"mesh {_name(mesh)} does not cross the plane z = {z:g} "
                        "(2-D cross-section is empty)")
    fn = np.asarray(mesh.face_normals)[faces][:, :2]
    dirn = seg[:, 1] - seg[:, 0]
    right = np.stack([dirn[:, 1], -dirn[:, 0]], axis=1)
    swap = (right * fn).sum(1) < 0
    seg[swap] = seg[swap][:, ::-1]
    seg = seg[np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1) > 1e-12 * max(size, 1.0)]
    return seg, z


def _indexed(seg: np.ndarray, size: float):
    """Shared vertices (merged to 1e-9 of the size) and edges of 2-D segments."""
    q = np.round(seg.reshape(-1, 2) / (1e-9 * max(size, 1e-9))).astype(np.int64)
    _, first, inv = np.unique(q, axis=0, return_index=True, return_inverse=True)
    V = np.ascontiguousarray(seg.reshape(-1, 2)[first], dtype=np.float64)
    E = np.ascontiguousarray(inv.reshape(-1, 2), dtype=np.int64)
    return V, E


def _segment_distance(V, E, x2, pseudonormal: bool):
    import igl
    kind = igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL if pseudonormal else igl.SIGNED_DISTANCE_TYPE_UNSIGNED
    s = igl.signed_distance(np.ascontiguousarray(x2, dtype=np.float64), V, E, kind)[0]
    return np.asarray(s, dtype=np.float64)


def mesh_section(mesh, z: float = 0.0):
    """SDF of the 2-D cross-section of a closed mesh by the plane at height ``z`` (its
    third coordinate): distance to the section's edges, negative inside (even-odd rule
    over the section's loops)."""
    from matplotlib.path import Path

    require_closed(mesh)
    seg, z = _section_segments(mesh, z)
    V, E = _indexed(seg, float(np.max(mesh.extents)))
    sec = mesh.section(plane_origin=[0, 0, z], plane_normal=[0, 0, 1])
    paths = [Path(np.asarray(sec.vertices)[e.points][:, :2]) for e in sec.entities] if sec else []

    def f(x):
        x2 = np.asarray(x, dtype=np.float64)[:, :2]
        if not len(x2):
            return np.zeros(0)
        d = np.abs(_segment_distance(V, E, x2, False))
        inside = np.zeros(len(x2), dtype=bool)
        for pth in paths:
            inside ^= pth.contains_points(x2)
        return np.where(inside, -d, d)
    return f


def mesh_section_shell(mesh, thickness: float, z: float = 0.0, behind: bool = True):
    """2-D cross-section of :func:`mesh_shell`: the shell of ``thickness`` behind (or in
    front of) the curves where the plane at height ``z`` cuts the surface."""
    T = float(thickness)
    seg, _ = _section_segments(mesh, z)
    V, E = _indexed(seg, float(np.max(mesh.extents)))
    sgn = 1.0 if behind else -1.0

    def f(x):
        x2 = np.asarray(x, dtype=np.float64)[:, :2]
        if not len(x2):
            return np.zeros(0)
        s = sgn * _segment_distance(V, E, x2, True)
        return np.abs(s + T / 2) - T / 2
    return f


# ------------------------------------------------------------------ placing and filling
def rotation_matrix(axis, degrees: float) -> np.ndarray:
    """3×3 matrix of the right-handed rotation by ``degrees`` about ``axis`` (Rodrigues'
    formula R = I + sin θ K + (1 − cos θ) K², K the cross-product matrix of the unit axis)."""
    a = np.asarray(axis, dtype=np.float64).reshape(3)
    n = float(np.linalg.norm(a))
    if not n > 0:
        raise DcdcError(f"rotation axis must be a non-zero vector (got {a.tolist()})")
    x, y, z = a / n
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    t = math.radians(float(degrees))
    return np.eye(3) + math.sin(t) * K + (1.0 - math.cos(t)) * (K @ K)


def load_placed_mesh(path, scale=1.0, translate=None, rotation_axis=None,
                     rotation_degrees: float = 0.0):
    """:func:`load_mesh`, scaled (one factor, or one per axis), then rotated by
    ``rotation_degrees`` about ``rotation_axis`` through the origin, then translated:
    x' = R (S x) + t, the order of SPlisHSPlasH's scene files. Positive scales and
    rotations keep a closed mesh closed and outward-wound."""
    mesh = load_mesh(path, scale)
    if rotation_axis is not None and rotation_degrees:
        T = np.eye(4)
        T[:3, :3] = rotation_matrix(rotation_axis, rotation_degrees)
        mesh.apply_transform(T)
    if translate is not None:
        mesh.apply_translation(np.asarray(translate, dtype=np.float64))
    return mesh


def mesh_interior(mesh, inset: float = 0.0, slice_z: float | None = None):
    """Inside test of a closed mesh: a predicate that is True for points at least
    ``inset`` inside it (3-D points), or, with ``slice_z``, inside its cross-section by the
    plane z = ``slice_z`` (2-D points). 3-D uses :func:`mesh_solid` with a band of
    ``inset``: exact wherever the answer depends on the distance, the fast winding number
    deeper inside."""
    require_closed(mesh, "a mesh fluid fills the inside of a closed mesh")
    if slice_z is None:
        sdf = mesh_solid(mesh, band=max(float(inset), 1e-6))
    else:
        sdf = mesh_section(mesh, slice_z)
    return lambda x: sdf(x) <= -float(inset) + 1e-9
