"""Apple-tree branch scenes: random geometry from a seed, and exact ray-cast stereo rendering.

A scene lives in the left camera frame (X right, Y down, Z forward, mm): branches (tapered tubes around
axis polylines, forks where a child's axis starts on its parent's axis), leaves (pointed elliptic discs),
apples (spheres), a textured background plane far behind, a directional light plus ambient.

Rendering casts one ray per supersample through each distorted camera (``cv2.undistortPoints`` of the
sample grid), intersects every primitive inside its projected bounding box, shades the nearest hit
(bark texture fixed to the branch surface), box-filters the supersamples, blurs slightly and adds
sensor noise, a gain difference between the cameras and optionally JPEG compression.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from appliance.synth import raycast
from appliance.synth.rig import Rig
from appliance.synth.texture import background_texture, bark_texture, fft_noise, lookup
from appliance.synth.truth import SceneTruth, TrueBranch, TrueFeatures

BACKGROUNDS = ("mixed", "foliage", "sky", "grass")
Z_RANGE_MM = (520.0, 1480.0)            # axis points stay inside; surfaces lie within 500-1500 mm
HALF_FOV = (0.44, 0.33)                  # normalised half extents of the nominal view, for placing things
BARK_MM_PER_TEXEL = 0.5
BACKGROUND_MM_PER_TEXEL = 5.0


@dataclass(frozen=True, eq=False)
class Scene:
    """Geometry and look of one scene (left camera frame, mm).

    Attributes
    ----------
    branches : list of TrueBranch
    leaf_centre, leaf_normal, leaf_u : ndarray (L, 3)
        Leaf centres, unit normals, unit in-plane long axes.
    leaf_size : ndarray (L, 2)
        Semi-axes (long, short), mm.
    leaf_colour : ndarray (L, 3)
        BGR 0..1.
    apple_centre : ndarray (A, 3)
    apple_radius : ndarray (A,)
    apple_redness : ndarray (A,)
        0 (green-yellow) .. 1 (red).
    background : str
        One of :data:`BACKGROUNDS`.
    background_mm : float
        Depth of the background plane.
    light_dir : ndarray (3,)
        Unit vector towards the light.
    ambient : float
    bark_colour : ndarray (3,)
        BGR 0..1.
    seed : int
    """

    branches: list
    leaf_centre: np.ndarray
    leaf_normal: np.ndarray
    leaf_u: np.ndarray
    leaf_size: np.ndarray
    leaf_colour: np.ndarray
    apple_centre: np.ndarray
    apple_radius: np.ndarray
    apple_redness: np.ndarray
    background: str
    background_mm: float
    light_dir: np.ndarray
    ambient: float
    bark_colour: np.ndarray
    seed: int


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _perpendicular(a: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to unit ``a``."""
    ref = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    return _unit(np.cross(a, ref))


def _grow(rng, start, direction, length_mm, r0, r1, parent, parent_vertex, curl=0.05, step_mm=30.0):
    """A branch as a random walk of ``step_mm`` steps, reflected to stay within :data:`Z_RANGE_MM`."""
    n = max(2, int(round(length_mm / step_mm)))
    pts = [np.asarray(start, float)]
    d = _unit(np.asarray(direction, float))
    for _ in range(n):
        d = _unit(d + rng.normal(0, curl, 3))
        p = pts[-1] + d * step_mm
        if not Z_RANGE_MM[0] <= p[2] <= Z_RANGE_MM[1]:
            d[2] = -d[2]
            p = pts[-1] + d * step_mm
        pts.append(p)
    radii = np.linspace(r0, r1, len(pts))
    return TrueBranch(np.array(pts), radii, parent, parent_vertex)


def _child_direction(rng, axis_dir, angle_deg):
    a = _unit(axis_dir)
    e1 = _perpendicular(a)
    e2 = np.cross(a, e1)
    phi = rng.uniform(0, 2 * np.pi)
    ang = np.radians(angle_deg)
    d = np.cos(ang) * a + np.sin(ang) * (np.cos(phi) * e1 + np.sin(phi) * e2)
    d[2] *= 0.6                                   # keep children mostly across the view
    return _unit(d)


def _add_children(rng, branches, parent, n_children, length_range, min_gap=3):
    """Laterals on ``branches[parent]`` at well-separated vertices; returns their indices."""
    pb = branches[parent]
    n = len(pb.axis_mm)
    candidates = np.arange(2, n - 2)
    rng.shuffle(candidates)
    chosen: list[int] = []
    for c in candidates:
        if len(chosen) == n_children:
            break
        if all(abs(c - o) >= min_gap for o in chosen):
            chosen.append(int(c))
    out = []
    for v in sorted(chosen):
        axis_dir = pb.axis_mm[v + 1] - pb.axis_mm[v]
        r_parent = pb.radius_mm[v]
        r0 = float(np.clip(rng.uniform(0.45, 0.7) * r_parent, 5.0, 16.0))
        child = _grow(rng, pb.axis_mm[v], _child_direction(rng, axis_dir, rng.uniform(35, 70)),
                      rng.uniform(*length_range), r0, rng.uniform(4.0, min(5.0, r0)), parent, v)
        branches.append(child)
        out.append(len(branches) - 1)
    return out


def _outside_point(rng, edge: str, z_mm: float) -> np.ndarray:
    """A point at depth ``z_mm`` just outside the nominal view on ``edge``."""
    hx, hy = HALF_FOV
    x, y = {
        "bottom": (rng.uniform(-0.5, 0.5) * hx, 1.25 * hy),
        "top": (rng.uniform(-0.5, 0.5) * hx, -1.25 * hy),
        "left": (-1.2 * hx, rng.uniform(-0.5, 0.5) * hy),
        "right": (1.2 * hx, rng.uniform(-0.5, 0.5) * hy),
    }[edge]
    return np.array([x * z_mm, y * z_mm, z_mm])


def _tree(rng) -> list:
    """Branches: a limb with laterals and sub-forks, a near-horizontal branch, a receding one."""
    branches: list = []
    # the limb: from below the view, upwards, oblique in depth
    z0 = rng.uniform(800, 1150)
    branches.append(_grow(rng, _outside_point(rng, "bottom", z0),
                          [rng.uniform(-0.4, 0.4), -1.0, rng.uniform(-0.35, 0.35)],
                          rng.uniform(700, 850), rng.uniform(18, 25), rng.uniform(8, 11), -1, -1, curl=0.04))
    laterals = _add_children(rng, branches, 0, int(rng.integers(3, 5)), (200, 420), min_gap=4)
    for lat in laterals:
        if rng.random() < 0.6:
            _add_children(rng, branches, lat, 1, (100, 220))
    # near-horizontal: from the left or right edge
    side = "left" if rng.random() < 0.5 else "right"
    zh = rng.uniform(620, 1350)
    sign = 1.0 if side == "left" else -1.0
    h = len(branches)
    branches.append(_grow(rng, _outside_point(rng, side, zh), [sign, rng.uniform(-0.06, 0.06),
                                                                 rng.uniform(-0.12, 0.12)],
                          rng.uniform(450, 650), rng.uniform(10, 15), rng.uniform(4.0, 5.0), -1, -1, curl=0.015))
    _add_children(rng, branches, h, 1, (120, 250))
    # receding: from the top edge, coming down and going away
    zr = rng.uniform(560, 700)
    branches.append(_grow(rng, _outside_point(rng, "top", zr),
                          [rng.uniform(-0.3, 0.3), 0.7, 0.7], rng.uniform(450, 650), rng.uniform(9, 14),
                          rng.uniform(4.0, 5.0), -1, -1, curl=0.03))
    return branches


def _away_from_features(rng, branches, gap=3):
    """A random (branch, vertex) at least ``gap`` vertices from the branch's ends and forks."""
    forks = {i: {0, len(b.axis_mm) - 1} for i, b in enumerate(branches)}
    for b in branches:
        if b.parent >= 0:
            forks[b.parent].add(b.parent_vertex)
    while True:
        i = int(rng.integers(len(branches)))
        v = int(rng.integers(1, len(branches[i].axis_mm) - 1))
        if all(abs(v - f) >= gap for f in forks[i]):
            return branches[i], v


def _leaves(rng, branches):
    """Leaf clusters along the outer part of each branch, plus leaves hanging in front of branches."""
    centre, normal, u_axis, size = [], [], [], []
    for b in branches:
        n = len(b.axis_mm)
        for v in range(n // 2, n - 1, 3):
            for _ in range(int(rng.integers(1, 3))):
                a = _unit(b.axis_mm[min(v + 1, n - 1)] - b.axis_mm[max(v - 1, 0)])
                out = _unit(np.cross(a, rng.normal(size=3)))
                semi = np.array([rng.uniform(28, 45), rng.uniform(13, 22)])
                centre.append(b.axis_mm[v] + out * (b.radius_mm[v] + semi[0] * rng.uniform(1.0, 1.5)))
                normal.append(_unit(rng.normal(size=3) + [0, -0.5, -1.0]))
                u_axis.append(out)
                size.append(semi)
    # occluders: a few leaves between the camera and a branch, cutting it in the image
    for _ in range(int(rng.integers(4, 7))):
        b, v = _away_from_features(rng, branches)
        p = b.axis_mm[v]
        centre.append(p * (1 - (b.radius_mm[v] + rng.uniform(25, 90)) / np.linalg.norm(p)))
        normal.append(_unit(rng.normal(0, 0.35, 3) + [0, 0, -1.0]))
        u_axis.append(_unit(rng.normal(size=3)))
        size.append(np.array([rng.uniform(30, 45), rng.uniform(14, 22)]))
    normal = np.array(normal)
    u_axis = np.array(u_axis)
    u_axis = _unit(u_axis - (u_axis * normal).sum(1, keepdims=True) * normal)   # in the leaf plane
    green = np.array([0.16, 0.48, 0.28])
    colour = green * rng.uniform(0.75, 1.25, (len(normal), 1)) + rng.normal(0, 0.03, (len(normal), 3))
    return np.array(centre), normal, u_axis, np.array(size), np.clip(colour, 0, 1)


def _apples(rng, branches):
    """Apples hanging under branches and one in front of a branch."""
    centre, radius = [], []
    for i in range(int(rng.integers(2, 5))):
        b, v = _away_from_features(rng, branches)
        r = rng.uniform(35, 45)
        p = b.axis_mm[v]
        if i == 0:      # in front of the branch
            centre.append(p * (1 - (b.radius_mm[v] + r + rng.uniform(10, 60)) / np.linalg.norm(p)))
        else:           # hanging below it
            centre.append(p + np.array([rng.normal(0, 10), b.radius_mm[v] + r + rng.uniform(15, 40),
                                        rng.normal(0, 10)]))
        radius.append(r)
    return np.array(centre), np.array(radius), rng.uniform(0.3, 1.0, len(radius))


def make_scene(seed: int) -> Scene:
    """A random branch scene, the same for the same ``seed``."""
    rng = np.random.default_rng(seed)
    branches = _tree(rng)
    leaves = _leaves(rng, branches)
    apples = _apples(rng, branches)
    light = _unit(np.array([rng.uniform(-0.7, 0.7), rng.uniform(-1.0, -0.4), rng.uniform(-0.9, -0.2)]))
    bark = np.array([0.27, 0.33, 0.40]) * rng.uniform(0.8, 1.2) + rng.normal(0, 0.02, 3)
    return Scene(branches, *leaves, *apples, BACKGROUNDS[seed % len(BACKGROUNDS)], rng.uniform(2500, 4500),
                 light, float(rng.uniform(0.35, 0.5)), np.clip(bark, 0, 1), int(seed))


# --------------------------------------------------------------------------------------------- rendering

@dataclass(frozen=True, eq=False)
class _Segments:
    """Every branch piece (S rows): ends, radii, owning branch, arc length at its start, a bark frame."""

    a: np.ndarray
    b: np.ndarray
    ra: np.ndarray
    rb: np.ndarray
    branch: np.ndarray
    s0: np.ndarray
    e1: np.ndarray
    e2: np.ndarray


def _segments(branches) -> _Segments:
    rows = []
    for i, br in enumerate(branches):
        axis, r = br.axis_mm, br.radius_mm
        e1 = _perpendicular(_unit(axis[1] - axis[0]))
        s = 0.0
        for k in range(len(axis) - 1):
            t = _unit(axis[k + 1] - axis[k])
            e1 = _unit(e1 - (e1 @ t) * t)                # parallel transport of the bark frame
            rows.append((axis[k], axis[k + 1], r[k], r[k + 1], i, s, e1, np.cross(t, e1)))
            s += float(np.linalg.norm(axis[k + 1] - axis[k]))
    cols = list(zip(*rows))
    return _Segments(*(np.array(c) for c in cols))


@dataclass(frozen=True, eq=False)
class _Hits:
    """Nearest hit per supersample of one camera: ray parameter, primitive id (-1 background)."""

    origin: np.ndarray      # (3,), left frame
    dirs: np.ndarray        # (H2, W2, 3) float32 unit, left frame
    t: np.ndarray           # (H2, W2) float64
    ids: np.ndarray         # (H2, W2) int32


@dataclass(frozen=True, eq=False)
class _Rays:
    """The supersample rays of one camera, which depend on the rig alone (not on the scene)."""

    origin: np.ndarray      # (3,), left frame, mm
    dirs: np.ndarray        # (H2, W2, 3) float32 unit, left frame; read-only (shared by every render)
    colmin: np.ndarray      # (W2,) least / greatest normalised x of each sample column
    colmax: np.ndarray
    rowmin: np.ndarray      # (H2,) least / greatest normalised y of each sample row
    rowmax: np.ndarray


_RAYS: dict = {}        # the rays of the last few (rig, side, ss): one render's two cameras, a few rigs
_RAYS_KEPT = 4


def _rays(rig: Rig, side: str, ss: int) -> _Rays:
    """The supersample rays of camera ``side`` of ``rig`` (``ss`` x ``ss`` per pixel), computed once per rig,
    side and ``ss`` and kept (two cameras at ss=2 hold ~120 MB): undistorting every sample's pixel
    (``cv2.undistortPoints`` of 5 M points) is a third of a render's time and the same for every scene."""
    K, D, Rc, tc = rig.camera(side)
    key = (side, ss, rig.width_px, rig.height_px) + tuple(np.asarray(a, np.float64).tobytes() for a in (K, D, Rc, tc))
    if key in _RAYS:
        return _RAYS[key]
    grid = rig.normalised_grid(side, ss)
    d_cam = np.concatenate([grid, np.ones(grid.shape[:2] + (1,))], axis=-1)
    d_cam /= np.linalg.norm(d_cam, axis=-1, keepdims=True)
    dirs = (d_cam @ Rc).astype(np.float32)            # d_left = Rc^T d_cam
    dirs.setflags(write=False)
    origin = -Rc.T @ tc
    origin.setflags(write=False)
    rays = _Rays(origin, dirs, grid[..., 0].min(0), grid[..., 0].max(0), grid[..., 1].min(1),
                 grid[..., 1].max(1))
    while len(_RAYS) >= _RAYS_KEPT:
        del _RAYS[next(iter(_RAYS))]
    _RAYS[key] = rays
    return rays


def _cast(scene: Scene, seg: _Segments, rig: Rig, side: str, ss: int) -> _Hits:
    """Nearest hit of every supersample ray of camera ``side``; each primitive is tested only inside the
    window of samples whose rays can reach its bounding sphere."""
    _, _, Rc, tc = rig.camera(side)
    rays = _rays(rig, side, ss)
    dirs, origin = rays.dirs, rays.origin
    colmin, colmax, rowmin, rowmax = rays.colmin, rays.colmax, rays.rowmin, rays.rowmax
    t_buf = np.full(dirs.shape[:2], np.inf)
    ids = np.full(dirs.shape[:2], -1, np.int32)

    def window(centre, radius):
        c = Rc @ centre + tc
        if c[2] - radius < 1.0:
            return slice(None), slice(None)
        lo, hi = c[2] - radius, c[2] + radius
        xs = ((c[0] - radius) / lo, (c[0] - radius) / hi, (c[0] + radius) / lo, (c[0] + radius) / hi)
        ys = ((c[1] - radius) / lo, (c[1] - radius) / hi, (c[1] + radius) / lo, (c[1] + radius) / hi)
        cols = np.nonzero((colmax >= min(xs)) & (colmin <= max(xs)))[0]
        rows = np.nonzero((rowmax >= min(ys)) & (rowmin <= max(ys)))[0]
        if len(cols) == 0 or len(rows) == 0:
            return None
        return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)

    def put(win, t, pid):
        tb = t_buf[win]
        nearer = t < tb
        tb[nearer] = t[nearer]
        ids[win][nearer] = pid

    pid = 0
    for k in range(len(seg.a)):
        win = window((seg.a[k] + seg.b[k]) / 2, np.linalg.norm(seg.b[k] - seg.a[k]) / 2 + max(seg.ra[k], seg.rb[k]))
        if win is not None:
            put(win, raycast.round_cone(origin, dirs[win].astype(np.float64), seg.a[k], seg.b[k],
                                        seg.ra[k], seg.rb[k]), pid)
        pid += 1
    for k in range(len(scene.leaf_centre)):
        win = window(scene.leaf_centre[k], scene.leaf_size[k, 0])
        if win is not None:
            t, _, _ = raycast.ellipse_disc(origin, dirs[win].astype(np.float64), scene.leaf_centre[k],
                                           scene.leaf_normal[k], scene.leaf_u[k],
                                           np.cross(scene.leaf_normal[k], scene.leaf_u[k]),
                                           *scene.leaf_size[k], shape_power=0.8)
            put(win, t, pid)
        pid += 1
    for k in range(len(scene.apple_centre)):
        win = window(scene.apple_centre[k], scene.apple_radius[k])
        if win is not None:
            put(win, raycast.sphere(origin, dirs[win].astype(np.float64), scene.apple_centre[k],
                                    scene.apple_radius[k]), pid)
        pid += 1
    bg = ids < 0
    t_buf[bg] = raycast.plane_z(origin, dirs[..., 2][bg].astype(np.float64), scene.background_mm)
    return _Hits(origin, dirs, t_buf, ids)


def _shade(scene: Scene, seg: _Segments, hits: _Hits, bark: np.ndarray, bg_tex: np.ndarray,
           spots: np.ndarray) -> np.ndarray:
    """BGR float32 colour (H2, W2, 3) of the nearest hits."""
    n_seg, n_leaf = len(seg.a), len(scene.leaf_centre)
    out = np.zeros(hits.ids.shape + (3,), np.float32)
    light = scene.light_dir
    flat_ids = hits.ids.ravel()
    t = hits.t.ravel()
    d32 = hits.dirs.reshape(-1, 3)
    col = out.reshape(-1, 3)

    def rays(idx, axis=None):   # the rays' directions (N, 3) float64, or one axis's (N,) (float32 -> float64: exact)
        return (d32.take(idx, axis=0) if axis is None else d32[:, axis].take(idx)).astype(np.float64)

    def point(idx):             # (take: rows of a 5 M x 3 array ~5x sooner than fancy indexing, the same values)
        return hits.origin + t.take(idx)[:, None] * rays(idx)

    idx = np.nonzero((flat_ids >= 0) & (flat_ids < n_seg))[0]                      # bark
    if len(idx):
        k = flat_ids[idx]
        p = point(idx)
        ab = seg.b[k] - seg.a[k]
        h = np.clip(((p - seg.a[k]) * ab).sum(1) / (ab * ab).sum(1), 0, 1)
        n = _unit(p - (seg.a[k] + h[:, None] * ab))
        along = seg.s0[k] + h * np.linalg.norm(ab, axis=1)
        theta = np.arctan2((n * seg.e2[k]).sum(1), (n * seg.e1[k]).sum(1))
        br = seg.branch[k]
        tex = lookup(bark, along / BARK_MM_PER_TEXEL + 577.0 * br, (theta / (2 * np.pi) + 0.37 * br) * bark.shape[0])
        lit = scene.ambient + (1 - scene.ambient) * np.clip(n @ light, 0, None)
        col[idx] = scene.bark_colour[None, :] * (tex * lit)[:, None]

    idx = np.nonzero((flat_ids >= n_seg) & (flat_ids < n_seg + n_leaf))[0]           # leaves
    if len(idx):
        k = flat_ids[idx] - n_seg
        p = point(idx)
        nrm = scene.leaf_normal[k]
        facing = np.where(((nrm * rays(idx)).sum(1) > 0)[:, None], -nrm, nrm)
        rel = p - scene.leaf_centre[k]
        u = (rel * scene.leaf_u[k]).sum(1) / scene.leaf_size[k, 0]
        v = (rel * np.cross(nrm, scene.leaf_u[k])).sum(1) / scene.leaf_size[k, 1]
        vein = 1 - 0.25 * np.exp(-(v / 0.06) ** 2) - 0.1 * np.exp(-((np.abs(v) - 0.5 * (u + 1) % 0.4) / 0.05) ** 2)
        ndl = facing @ light
        lit = scene.ambient + (1 - scene.ambient) * np.clip(ndl, 0, None) + 0.25 * np.clip(-ndl, 0, None)
        grain = 1 + 0.06 * lookup(spots, u * 40 + 13 * k, v * 20)
        col[idx] = scene.leaf_colour[k] * (vein * lit * grain)[:, None]

    idx = np.nonzero(flat_ids >= n_seg + n_leaf)[0]                                  # apples
    if len(idx):
        k = flat_ids[idx] - n_seg - n_leaf
        p = point(idx)
        n = (p - scene.apple_centre[k]) / scene.apple_radius[k, None]
        blotch = lookup(spots, (np.arctan2(n[:, 0], n[:, 2]) + np.pi) * 12 + 50 * k, (n[:, 1] + 1) * 20)
        red = np.clip(scene.apple_redness[k] + 0.35 * blotch, 0, 1)[:, None]
        base = red * np.array([0.12, 0.12, 0.70]) + (1 - red) * np.array([0.25, 0.65, 0.62])
        ndl = n @ light
        refl = light - 2 * ndl[:, None] * n
        spec = 0.45 * np.clip((refl * rays(idx)).sum(1), 0, None) ** 25
        lit = scene.ambient + (1 - scene.ambient) * np.clip(ndl, 0, None)
        col[idx] = base * lit[:, None] + spec[:, None]

    idx = np.nonzero(flat_ids < 0)[0]                                                # background
    if len(idx):
        ti = t.take(idx)                    # the hit's X and Y alone (point()'s values; Z is the plane's)
        x, y = (hits.origin[a] + ti * rays(idx, a) for a in (0, 1))
        col[idx] = lookup(bg_tex, x / BACKGROUND_MM_PER_TEXEL + bg_tex.shape[1] / 2,
                          y / BACKGROUND_MM_PER_TEXEL + bg_tex.shape[0] / 2)
    return out


def _box_mean(img: np.ndarray, ss: int) -> np.ndarray:
    """The mean of each pixel's ``ss`` x ``ss`` supersamples of a float32 image (H*ss, W*ss, C) -> (H, W, C).

    ``img.reshape(h, ss, w, ss, C).mean(axis=(1, 3))``'s values bit for bit (numpy adds a pixel's supersamples
    in this order; checked for ss 1-8), ~5x sooner: the sum runs over whole (H, W, C) planes."""
    a = img.reshape(img.shape[0] // ss, ss, img.shape[1] // ss, ss, -1)
    acc = a[:, 0, :, 0]
    for i in range(ss):
        for j in range(ss):
            if i or j:
                acc = acc + a[:, i, :, j]
    return acc / np.float32(ss * ss)


def _sensor(img: np.ndarray, rng: np.random.Generator, gain: float, jpeg_quality: int | None) -> np.ndarray:
    """Optics blur, gain, signal-dependent noise, 8-bit quantisation and optional JPEG."""
    x = cv2.GaussianBlur(img, (0, 0), 0.55) * (255.0 * gain)
    sigma = np.sqrt(0.8 + 0.012 * np.clip(x, 0, None))
    x = x + sigma * rng.standard_normal(x.shape, dtype=np.float32)
    out = np.clip(np.round(x), 0, 255).astype(np.uint8)
    if jpeg_quality is not None:
        _, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
        out = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    return out


def _shows(hits: _Hits, owner: np.ndarray, rig: Rig, ss: int, points_mm: np.ndarray, points_px: np.ndarray,
           allowed: list, reach_mm: list) -> np.ndarray:
    """Whether most supersamples of each point's pixel hit one of its ``allowed`` branches no more than
    ``reach_mm`` before the point (so neither something else nor the branch itself hides it), (N,) bool."""
    out = np.zeros(len(points_px), bool)
    for j, (u, v) in enumerate(points_px):
        ui, vi = int(round(u)), int(round(v))
        if not (1 <= ui < rig.width_px - 1 and 1 <= vi < rig.height_px - 1):
            continue
        block = (slice(vi * ss, (vi + 1) * ss), slice(ui * ss, (ui + 1) * ss))
        k, t = hits.ids[block].ravel(), hits.t[block].ravel()
        own = (k >= 0) & (k < len(owner)) & np.isin(owner[np.clip(k, 0, len(owner) - 1)], allowed[j])
        dist = np.linalg.norm(points_mm[j] - hits.origin)
        out[j] = (own & (t >= dist - reach_mm[j])).sum() * 2 > ss * ss
    return out


def _reach(b: TrueBranch, v0: int, point: np.ndarray, origin: np.ndarray) -> float:
    """How far before ``point`` (at vertex ``v0`` of ``b``) the tube's own surface may be along the ray from
    ``origin``: r / sin(ray, axis), the sine bounded below (a tube seen end-on hides its own tip)."""
    a = _unit(b.axis_mm[min(v0 + 1, len(b.axis_mm) - 1)] - b.axis_mm[max(v0 - 1, 0)])
    sin = np.sqrt(max(1 - float(a @ _unit(point - origin)) ** 2, 0.0))
    return 1.1 * b.radius_mm[v0] / max(sin, 0.3) + 1.0


def _features(scene: Scene, rig: Rig, seg: _Segments, hits: dict, ss: int) -> TrueFeatures:
    """Tips and forks with their projections and visibility in each view."""
    rows = []
    for i, b in enumerate(scene.branches):
        if b.parent >= 0:
            rows.append(("bifurcation", b.axis_mm[0], i, b.parent, b.radius_mm[0]))
        rows.append(("endpoint", b.axis_mm[-1], i, -1, b.radius_mm[-1]))
    kind = np.array([r[0] for r in rows], dtype="<U11")
    xyz = np.array([r[1] for r in rows], float).reshape(-1, 3)
    branch = np.array([r[2] for r in rows], int)
    parent = np.array([r[3] for r in rows], int)
    radius = np.array([r[4] for r in rows], float)
    br = scene.branches
    allowed = [[branch[j], parent[j]] if parent[j] >= 0 else [branch[j]] for j in range(len(kind))]
    px, vis = {}, {}
    for side in ("left", "right"):
        h = hits[side]
        px[side] = rig.project(xyz, side)
        reach = [_reach(br[branch[j]], len(br[branch[j]].axis_mm) - 1, xyz[j], h.origin) if parent[j] < 0 else
                 _reach(br[parent[j]], br[branch[j]].parent_vertex, xyz[j], h.origin) for j in range(len(kind))]
        v = _shows(h, seg.branch, rig, ss, xyz, px[side], allowed, reach)
        # a fork counts only where its child is seen leaving the parent (within a few child radii of it)
        for j in np.nonzero((kind == "bifurcation") & v)[0]:
            b = br[branch[j]]
            step = br[parent[j]].radius_mm[b.parent_vertex] + 2 * b.radius_mm[0]
            p = np.array([_point_along(b.axis_mm, m * step) for m in (1.0, 1.5, 2.0, 3.0)])
            v[j] = _shows(h, seg.branch, rig, ss, p, rig.project(p, side), [[branch[j]]] * len(p),
                          [_reach(b, 0, q, h.origin) for q in p]).any()
        vis[side] = v
    return TrueFeatures(kind, xyz, px["left"], px["right"], vis["left"], vis["right"], branch, parent, radius)


def _point_along(axis: np.ndarray, dist_mm: float) -> np.ndarray:
    """The point ``dist_mm`` along a polyline from its start (its end if shorter)."""
    seg_len = np.linalg.norm(np.diff(axis, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])
    k = int(np.clip(np.searchsorted(cum, dist_mm) - 1, 0, len(seg_len) - 1))
    f = np.clip((dist_mm - cum[k]) / seg_len[k], 0, 1)
    return axis[k] + f * (axis[k + 1] - axis[k])


def render(scene: Scene, rig: Rig, seed: int = 0, ss: int = 2, jpeg_quality: int | None = None):
    """Render a stereo pair of ``scene`` through ``rig``, with exact truth.

    Parameters
    ----------
    scene : Scene
    rig : Rig
    seed : int
        Seed of the sensor noise and the gain difference.
    ss : int
        Supersamples per pixel along each axis (anti-aliasing).
    jpeg_quality : int or None
        Compress both images as JPEG of this quality.

    Returns
    -------
    left_bgr, right_bgr : ndarray (H, W, 3) uint8
    truth : SceneTruth
    """
    rng = np.random.default_rng(seed)
    tex_rng = np.random.default_rng(scene.seed + 7919)
    bark = bark_texture(tex_rng)
    spots = fft_noise((256, 256), tex_rng, beta=1.5)
    bg_tex = background_texture(scene.background, tex_rng)
    seg = _segments(scene.branches)
    w, h = rig.size
    images, hits, cover, depth = {}, {}, {}, None
    gains = {"left": 1.0, "right": 1.0 + rng.uniform(-0.06, 0.06)}
    for side in ("left", "right"):
        hits[side] = hs = _cast(scene, seg, rig, side, ss)
        colour = _shade(scene, seg, hs, bark, bg_tex, spots)
        img = _box_mean(colour, ss)
        images[side] = _sensor(img, rng, gains[side], jpeg_quality)
        on_branch = (hs.ids >= 0) & (hs.ids < len(seg.a))
        cover[side] = on_branch.reshape(h, ss, w, ss).mean(axis=(1, 3))
        if side == "left":
            z = np.where(on_branch, hs.t * hs.dirs[..., 2], 0.0).reshape(h, ss, w, ss).sum(axis=(1, 3))
            n = on_branch.reshape(h, ss, w, ss).sum(axis=(1, 3))
            with np.errstate(invalid="ignore", divide="ignore"):
                depth = np.where(cover["left"] >= 0.5, z / n, np.nan).astype(np.float32)
    features = _features(scene, rig, seg, hits, ss)
    truth = SceneTruth(rig, list(scene.branches), features, depth, cover["left"] >= 0.5, cover["right"] >= 0.5,
                       scene.seed, *(cover[side].astype(np.float32) for side in ("left", "right")))
    return images["left"], images["right"], truth
