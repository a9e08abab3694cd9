"""Where a fork placed from its child's outline lies against the truth, and where other readings of the same
mask would place it (issue 5, stop 30: the shallow child's place ahead of its fork).

For every true fork seen in both views whose junction ``ForkPlacing.fork`` placed from the child's outline
(traced as in ``fork_misses.py``), the left mask is scanned on lines parallel to the parent's line the outline
used (``outline``), at heights ``h`` from the parent's radius ``r`` to ``r + 3 + 3 r_child`` (0.5 px apart) on the
child's side: the run of coverage >= 128 (bilinear, ends interpolated) nearest the child's expected crossing is
the child's interval ``[s_out(h), s_in(h)]`` (``s_in``: the end on the acute side, towards the crotch). The
readings, each an offset (px) of the place from the true fork along the parent's line (+: towards the child's
outward side):

- ``cur``: the place as made (the child's outline lines at ``r + 3`` and ``r + 3 + 1.5 r_child``);
- ``mid2``: the same two middles read here (checks the scan);
- ``crotch``: the crotch (``s_in`` at the lowest height where the child's interval stands alone, ``h0``) less
  ``(h0 cos t + r_c) / sin t``, ``t`` the two middles' angle;
- ``low``: the middle at ``h0`` less ``h0 cot t`` (the two middles' angle, carried from nearer the parent);
- ``width``: the middle at ``h0`` less ``h0 cot t_w``, ``sin t_w = 2 r_c / width(h0)`` (the angle from the
  interval's width next to the parent);
- ``fit``: the line through all middles from ``h0`` to ``h0 + 2 r_c`` (least squares) carried to the axis;
- ``outer``: the child's outer (obtuse-side) edge ``s_out`` from ``r + 1.5`` to ``r + 1.5 + max(6, r_c)``, a
  line ``s = h cot t_o - r_c / sin t_o`` fitted and carried to the axis.

Also the scan's angles (``t2``: the two middles', ``tw``, ``tf``, ``to``: the readings') and the truth's
(``true_angles``: ``dpar`` the placed parent line's angle to the true parent's, ``tnear`` / ``tout`` the child's
inside the parent's silhouette / across the outline lines), deg. Forks whose junction lies within 200 px and
place within 40 px of the true fork; the child's angle (``t``) at most ``--max-deg``.

Usage: ``fork_crotch.py --seeds 996-1027 [--masks colour] [-v]``; prints one row per fork and the median error
and the count within 5 px per child-angle band (docs/localize-forkoff30.md).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fork_misses as fm  # noqa: E402
from appliance.localize import forkends  # noqa: E402
from appliance.synth.truth import load_truth  # noqa: E402
from appliance.synth.evaluate import score_result  # noqa: E402


def scan(mask: np.ndarray, c: np.ndarray, e: np.ndarray, n: np.ndarray, h: float, s_exp: float, reach: float):
    """The run of coverage >= 128 on the line ``c + h n + s e`` nearest ``s_exp``: (s_lo, s_hi) or None (px)."""
    s = np.arange(s_exp - reach, s_exp + reach, 0.25)
    pts = c + h * n + s[:, None] * e
    v = cv2.remap(mask.astype(np.float32), pts[:, 0].astype(np.float32)[None], pts[:, 1].astype(np.float32)[None],
                  cv2.INTER_LINEAR, borderValue=0)[0] - 128.0
    on = v >= 0
    if not on.any():
        return None
    idx = np.flatnonzero(on)
    k = idx[np.abs(s[idx] - s_exp).argmin()]
    lo, hi = k, k
    while lo > 0 and on[lo - 1]:
        lo -= 1
    while hi < len(s) - 1 and on[hi + 1]:
        hi += 1
    if lo == 0 or hi == len(s) - 1:
        return None

    def cross(i, j):                     # the 128 crossing between samples i (off) and j (on)
        return s[i] + (s[j] - s[i]) * (-v[i]) / (v[j] - v[i])
    return cross(lo - 1, lo), cross(hi + 1, hi)


def readings(rec: dict, uv: np.ndarray) -> dict | None:
    mask = rec["mask"]
    cl, el = (np.asarray(v, float) for v in rec["outline"])
    e2, c2, xy = rec["e2"], rec["c2"], rec["xy"]
    out = e2 if np.dot(c2 - xy, e2) >= 0 else -e2
    e = el if np.dot(out, el) >= 0 else -el
    n = np.array([-e[1], e[0]])
    n = n if np.dot(out, n) >= 0 else -n
    r, rc = float(rec["r_par"]), float(rec["rad"][rec["child"]])
    sin_t = abs(e[0] * out[1] - e[1] * out[0])
    cot = np.dot(out, e) / max(np.dot(out, n), 1e-6)
    s_x = np.dot(xy - cl, e)
    s_true = np.dot(uv - cl, e)
    res = {"t": np.degrees(np.arcsin(min(1.0, sin_t))), "r": r, "rc": rc, "cur": s_x - s_true,
           "across": float(np.dot(xy - uv, n))}
    reach = (4.7 * rc + 3) / max(sin_t, 0.2) + 2
    hs = np.arange(r, r + 3 + 3 * rc + 6, 0.5)
    runs = {}
    for h in hs:
        q = scan(mask, cl, e, n, h, s_x + h * cot, reach)
        if q is not None:
            runs[float(h)] = q
    w_max = 2 * rc / max(sin_t, 0.2) * 1.6 + 6
    clean = [h for h, (a, b) in runs.items() if b - a <= w_max]
    if len(clean) < 3:
        return res
    # the child's interval alone: its width within 10 % (+1 px) of the median width further out (up to r + 3 + 3 r_c)
    w_far = np.median([runs[h][1] - runs[h][0] for h in clean if h >= r + 3])
    clean = [h for h in clean if runs[h][1] - runs[h][0] <= 1.1 * w_far + 1.0]
    if len(clean) < 3:
        return res
    h0 = clean[0]
    res["prof"] = " ".join(f"{h - r:.1f}:{runs[h][1] - runs[h][0]:.1f}" for h in sorted(runs) if h <= r + 8)
    step = max(1.5 * rc, 6.0)
    h1, h2 = r + 3.0, r + 3.0 + step
    mid = {h: 0.5 * (a + b) for h, (a, b) in runs.items()}
    m = lambda h: mid.get(min(mid, key=lambda k: abs(k - h)))  # noqa: E731
    m1, m2 = m(h1), m(h2)
    cot2 = (m2 - m1) / step
    res["mid2"] = m1 - cot2 * h1 - s_true
    t2 = np.arctan2(1.0, cot2)
    res["t2"] = np.degrees(t2)
    a0, b0 = runs[h0]
    res["h0"] = h0 - r
    res["crotch"] = b0 - (h0 * np.cos(t2) + rc) / np.sin(t2) - s_true
    res["low"] = 0.5 * (a0 + b0) - h0 * cot2 - s_true
    w0 = b0 - a0
    if w0 > 2 * rc:
        tw = np.arcsin(2 * rc / w0)
        res["width"] = 0.5 * (a0 + b0) - h0 / np.tan(tw) - s_true
        res["tw"] = np.degrees(tw)
    ho = np.array([h for h in runs if r + 1.5 <= h <= r + 1.5 + max(6.0, rc)])
    if len(ho) >= 4:
        so = np.array([runs[h][0] for h in ho])
        k, b = np.polyfit(ho, so, 1)            # the outer edge: s = (h cos t - r_c) / sin t = h cot t - r_c / sin t
        to = np.arctan2(1.0, k)
        if 0.05 < to < 1.5:
            res["outer"] = b + rc / np.sin(to) - s_true
            res["to"] = np.degrees(to)
    hh = np.array([h for h in clean if h <= h0 + 2 * rc])
    if len(hh) >= 3:
        mm = np.array([mid[h] for h in hh])
        A = np.vstack([hh, np.ones_like(hh)]).T
        k, b = np.linalg.lstsq(A, mm, rcond=None)[0]
        res["fit"] = b - s_true
        res["tf"] = np.degrees(np.arctan2(1.0, k))
    return res


def true_angles(truth, calib, j: int, rec: dict, uv: np.ndarray) -> dict:
    """The truth's directions at fork ``j`` (rectified left view): the parent's axis within 40 px of the fork and
    the child's axis where it crosses the outline lines (heights ``r + 3`` to ``r + 3 + 1.5 r_c``), each as its
    angle (deg) to the parent's line the place used (``dpar``) and to the truth parent's (``tchild``); ``tnear``:
    the child's angle to the truth parent over its first ``r`` px of height (inside the parent's silhouette)."""
    tf = truth.features
    ch, pa = truth.branches[tf.branch[j]], truth.branches[tf.parent[j]]
    _, cp, _ = fm._resample(np.asarray(ch.axis_mm), np.asarray(ch.radius_mm))
    _, pp, _ = fm._resample(np.asarray(pa.axis_mm), np.asarray(pa.radius_mm))
    cpx = fm.rectified_points(calib, truth.rig.project(cp, "left"), 0)
    ppx = fm.rectified_points(calib, truth.rig.project(pp, "left"), 0)
    el = np.asarray(rec["outline"][1], float)
    near = ppx[np.hypot(*(ppx - uv).T) < 40]
    if len(near) < 5:
        return {}
    c = near.mean(0)
    ep = np.linalg.svd(near - c)[2][0]
    ep = ep if np.dot(ep, el) >= 0 else -ep
    n = np.array([-ep[1], ep[0]])
    h = (cpx - uv) @ n
    n = n if np.median(h[:20]) >= 0 else -n
    h = np.abs(h)
    r, rc = float(rec["r_par"]), float(rec["rad"][rec["child"]])

    def ang(sel):
        pts = cpx[sel]
        if len(pts) < 3:
            return np.nan
        d = np.linalg.svd(pts - pts.mean(0))[2][0]
        return float(np.degrees(np.arcsin(min(1.0, abs(d[0] * ep[1] - d[1] * ep[0])))))
    first = np.argmax(h > r + 3 + 1.5 * rc) if (h > r + 3 + 1.5 * rc).any() else len(h)
    out = {"dpar": float(np.degrees(np.arcsin(min(1.0, abs(el[0] * ep[1] - el[1] * ep[0])))) *
                         np.sign(el[0] * ep[1] - el[1] * ep[0]))}
    out["tchild"] = ang(np.arange(len(h)) < first) if first < len(h) else np.nan
    sel = (h >= r + 3) & (np.arange(len(h)) < first)
    out["tout"] = ang(sel)
    out["tnear"] = ang((h <= r) & (np.arange(len(h)) < first))
    return out


def right_view(rec: dict, uv: np.ndarray, uv_r: np.ndarray) -> dict:
    """The right view's place from the child's outline (the first ``right`` record with a place: the outline
    check's, ``_outline_agrees``) against the true fork there ``uv_r`` (rectified right view): ``right`` its
    offset along the parent's line (px, the left's sense), ``both`` the mean of it and the left's (``cur``)."""
    e2, c2, xy = rec["e2"], rec["c2"], rec["xy"]
    out = e2 if np.dot(c2 - xy, e2) >= 0 else -e2
    el = np.asarray(rec["outline"][1], float)
    e = el if np.dot(out, el) >= 0 else -el
    for c, er, p in rec.get("right", []):
        if p is not None:
            er = er if np.dot(er, e) >= 0 else -er
            right = float(np.dot(p - uv_r, er))
            return {"right": right, "both": 0.5 * (right + float(np.dot(xy - uv, e)))}
    return {}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", metavar="A-B", type=fm._seed_range)
    ap.add_argument("--extra", type=int, default=56)
    ap.add_argument("--masks", choices=["true", "colour"], default="true")
    ap.add_argument("--max-deg", type=float, default=45.0)
    ap.add_argument("-v", action="store_true", help="also the interval widths per height (h - r: width, px)")
    a = ap.parse_args()
    loc = fm.improved_localizer([])
    calib = loc.calib
    trace = fm.ForkTrace()
    traced = forkends.ForkPlacing.fork

    def fork(placer, node, final=False, needed=True):
        out = traced(placer, node, final, needed)
        rec = trace.recs.get(int(node))
        if rec is not None:
            rec["mask"] = placer.sm.left_mask
        return out
    forkends.ForkPlacing.fork = fork
    keys = ("cur", "mid2", "crotch", "low", "width", "fit", "outer", "right", "both")
    rows = []
    for name, lp, rp, tp in fm.scene_list(a.extra, a.seeds):
        if not (tp.exists() and lp.exists() and rp.exists()):
            continue
        truth = load_truth(tp)
        kw = dict(zip(("mask_left", "mask_right"), truth.exact_masks(soft=False))) if a.masks == "true" else {}
        trace.recs = {}
        res = loc.localize(cv2.imread(str(lp)), cv2.imread(str(rp)), **kw)
        tf = truth.features
        srows = [r for r in score_result(res, truth, name=name).rows if r.kind == "bifurcation"]
        for r in srows:
            j = r.truth_index
            if j < 0 or not (tf.visible_left[j] and tf.visible_right[j]):
                continue
            uv = fm.rectified_points(calib, tf.left_px[j], 0)[0]
            near = [(np.hypot(*(rec["xy"] - uv)), rec) for rec in trace.recs.values()
                    if "xy" in rec and rec.get("outline") is not None and not rec.get("along")
                    and "mask" in rec and np.hypot(*(rec["node_xy"] - uv)) < 200]
            near = [q for q in near if q[0] < 40]
            if not near:
                continue
            off, rec = min(near, key=lambda q: q[0])
            q = readings(rec, uv)
            if q is None or q["t"] > a.max_deg:
                continue
            q.update(true_angles(truth, calib, j, rec, uv))
            q.update(right_view(rec, uv, fm.rectified_points(calib, tf.right_px[j], 1)[0]))
            q.update(name=name, j=j, off=off, found=r.result_id >= 0)
            rows.append(q)
            g = lambda k: q.get(k, np.nan)  # noqa: E731
            print(f"{name} T{j}: {'found' if q['found'] else 'missed'} off {off:5.1f} t {q['t']:4.1f}"
                  f" t2 {g('t2'):4.1f} tw {g('tw'):4.1f} tf {g('tf'):4.1f} to {g('to'):4.1f}"
                  f" | truth dpar {g('dpar'):+4.1f} tnear {g('tnear'):4.1f} tout {g('tout'):4.1f} |"
                  f" r {q['r']:4.1f}/{q['rc']:4.1f} h0 {g('h0'):+4.1f} across {q['across']:+5.1f} | "
                  + " ".join(f"{k} {g(k):+6.1f}" for k in keys) + (f"\n    widths {q['prof']}" if a.v else ""))
    print()
    for lo, hi in ((0, 25), (25, 35), (35, 45)):
        sel = [q for q in rows if lo <= q["t"] < hi]
        if not sel:
            continue
        parts = []
        for k in keys:
            v = np.array([abs(q[k]) for q in sel if k in q])
            w5 = int(np.sum(v <= 5.0))
            parts.append(f"{k} med {np.median(v):4.1f} <=5px {w5}/{len(v)}" if len(v) else f"{k} -")
        print(f"t {lo}-{hi} deg, {len(sel)} forks: " + "; ".join(parts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
