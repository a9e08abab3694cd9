"""How each true tip's cap shows in a view: free, cut, run on or touched.

A tip is where a branch's axis ends; the renderer closes the branch there with a sphere of the tip's
radius, so a tip shows as a round end (a half disc beyond the axis' end) in each view. Recall counts a
tip as seen when its centre pixel shows its branch (``TrueFeatures.visible_*``), which does not ask
whether its end is seen: a cap behind a leaf or an apple ("cut"), continued by another branch's
outline ("runs") or lying against another branch ("touched") shows no end at all. This module reads
the cap in the exact masks of the truth so that tips can also be counted over free caps.

The reading (docs/localize-tiprec.md): along the true axis beyond the tip's centre and on the lines
0.7 r to either side of it (r: the tip's radius in the view, px), the mask must end within
``-SHORT_PX ... +LONG_PX`` of where the sphere's outline ends, and a half ring ``r + 2 ... r + 3.5`` px
around the centre (+-100 deg about the outward direction) must be at most ``RING_SHARE`` mask.
"""

from __future__ import annotations

import numpy as np

from appliance.synth.truth import SceneTruth

SHORT_PX = 2.0          # a line ending this much before the sphere's outline is cut (an occluder in front)
LONG_PX = 2.5           # ... running this much past it is continued by another branch
RING_PX = (2.0, 3.5)    # the half ring beyond the outline, px past r
RING_DEG = 100.0        # ... within this angle of the outward direction
RING_SHARE = 0.12       # ... is touched when more of it than this is branch
SIDE = 0.7              # the side lines' offset from the axis, in r
STEP_PX = 0.25          # sampling step along the lines, px


def cap_reading(mask: np.ndarray, centre_px: np.ndarray, outward: np.ndarray, radius_px: float) -> str:
    """How one cap shows in a binary mask.

    Parameters
    ----------
    mask : ndarray (H, W) bool
        Exact branch mask of the view (visible branch pixels; occluded ones are not in it).
    centre_px : ndarray (2,)
        The tip's axis end in the view, px (x, y), pixel centres at integers.
    outward : ndarray (2,)
        Unit direction of the axis beyond the tip in the view.
    radius_px : float
        The tip's radius in the view, px.

    Returns
    -------
    str
        ``"free"``, ``"cut"`` (a line ends early or leaves the image), ``"runs"`` (a line runs on past the
        outline) or ``"touched"`` (the ring beyond the cap meets branch pixels).
    """
    h, w = mask.shape
    normal = np.array([-outward[1], outward[0]])
    r = max(float(radius_px), 1.0)
    offsets = np.array([0.0, SIDE, -SIDE])
    expected = r * np.sqrt(1.0 - offsets ** 2)                      # where the sphere's outline ends, px
    t = np.arange(0.0, r + LONG_PX + 1.0, STEP_PX)
    pts = (centre_px[None, None, :] + offsets[:, None, None] * r * normal
           + t[None, :, None] * outward)                            # (3, T, 2)
    ij = np.rint(pts).astype(int)
    inside = (ij[..., 0] >= 0) & (ij[..., 0] < w) & (ij[..., 1] >= 0) & (ij[..., 1] < h)
    if not inside.all():
        return "cut"
    on = mask[ij[..., 1], ij[..., 0]]
    off = ~on
    first_off = np.where(off.any(axis=1), off.argmax(axis=1), len(t))
    end = t[np.minimum(first_off, len(t) - 1)] - np.where(first_off < len(t), STEP_PX / 2, 0.0)
    if (first_off >= len(t)).any() or (end > expected + LONG_PX).any():
        return "runs"
    if (end < expected - SHORT_PX).any():
        return "cut"
    rho = np.arange(r + RING_PX[0], r + RING_PX[1] + 1e-9, 0.5)
    ang = np.deg2rad(np.arange(-RING_DEG, RING_DEG + 1e-9, 5.0))
    base = np.arctan2(outward[1], outward[0])
    ring = centre_px + rho[:, None, None] * np.stack([np.cos(base + ang), np.sin(base + ang)], -1)[None]
    ij = np.rint(ring.reshape(-1, 2)).astype(int)
    ok = (ij[:, 0] >= 0) & (ij[:, 0] < w) & (ij[:, 1] >= 0) & (ij[:, 1] < h)
    share = mask[ij[ok, 1], ij[ok, 0]].mean() if ok.any() else 0.0
    return "touched" if share > RING_SHARE else "free"


def cap_readings(truth: SceneTruth) -> list[tuple[str, str] | None]:
    """Each true feature's cap reading in the (left, right) view; None for forks and for tips not seen
    in both views.

    Returns
    -------
    list of (str, str) or None, one per ``truth.features`` row
    """
    tf, rig = truth.features, truth.rig
    out: list[tuple[str, str] | None] = [None] * len(tf)
    for j in np.flatnonzero((tf.kind == "endpoint") & tf.visible_left & tf.visible_right):
        axis = truth.branches[int(tf.branch[j])].axis_mm
        tip = tf.xyz_mm[j]
        back = axis[-2] if len(axis) > 1 else axis[-1]
        d = tip - back
        d = d / max(np.linalg.norm(d), 1e-9)
        reading = []
        for side, mask in (("left", truth.mask_left), ("right", truth.mask_right)):
            K, _, Rc, tc = rig.camera(side)
            p0, p1 = rig.project(np.stack([tip, tip + d]), side)
            u = p1 - p0
            norm = np.linalg.norm(u)
            if norm < 1e-6:                      # the branch points straight at the camera: no round end
                reading.append("cut")
                continue
            z_cam = float((Rc @ tip + tc)[2])
            reading.append(cap_reading(mask, p0, u / norm, K[0, 0] * float(tf.radius_mm[j]) / z_cam))
        out[j] = (reading[0], reading[1])
    return out


def free_caps(truth: SceneTruth) -> np.ndarray:
    """Whether each true feature is a tip whose cap is free in both views (bool, one per feature)."""
    return np.array([r == ("free", "free") for r in cap_readings(truth)], bool)
