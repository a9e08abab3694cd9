"""Every true fork the improved localizer misses, by cause (issue 5's fork recall), from a trace of ForkPlacing.fork.

    python benchmarks/fork_misses.py [--extra N | --seeds A-B] [--masks true|colour] [-v] [--pickle OUT]
                                     [--set MODULE.NAME=VALUE ...] [--junctions] [--false]

Scenes as ``localize_accuracy.py`` (fixtures plus ``--extra`` seeds 100.., or ``--seeds A-B``), read from the
cache only: a scene not rendered yet is skipped, never rendered. Each pair runs the improved localizer with
``ForkPlacing.fork`` traced (``sys.settrace`` on that one frame: its locals at every line and at its return;
the code is not copied, so it follows any change to it as long as its local names ``agree``, ``outline``,
``parents``, ``child``, ``xy``, ``d`` stay). A true fork seen in both views and not found (5 px, the
evaluator's match) is put down to the fork junction nearest it (its skeleton node within 40 px, the place
``fork`` gave it in the rectified left image):

- ``no junction``: no node within 40 px (the skeleton has no junction there);
- by the place's distance (``within 5`` / ``5-40`` / ``>40`` px, rectified: a few forks 4-5 px off here are
  5+ px off in the original image) and what ``fork`` did: ``reported`` (placed, reported, not matched),
  ``not placed``, ``no parent piece`` (no parent curve through the place), ``no child outline`` (the slide
  back), ``child not confirmed`` (``agree`` never true: no child curve agreeing, the right outline, texture
  and row-crossing checks all failing) or ``withheld at LINE`` (a rule turning ``agree`` false after it was
  true, with the line's source).

``-v`` prints one line per missed fork: the fork's disparity against the true one (rectified), the child's
curve (minus the fork's), the angles (child to parent, child to the rows), radii, and the right outline's place
along the parent's axis (the outline check's offset, px). ``--set forkends.SECTIONS_MIN_MOVE_PX=0.0`` sets a
module constant of ``appliance.localize`` first (an experiment without editing the code); ``--pickle`` keeps
the records for other analyses.

``--false`` also classes every false fork (a reported fork matched to no true one) by where it lies against the
truth (``false_fork``: placed off a missed true fork, a second place of a found one, a tip on a branch, a crossing,
on one branch, off the axes), and for the placed-off ones how (``placed_off``: the offset along and across the
parent's line, the child's angle, the junction's distance; docs/localize-forks29.md).

``--junctions`` splits the forks with no junction by cause (``junction_split``, ``no_junction_cause``): the
skeleton's stages of the left mask (recorded by wrapping the names ``localizer`` calls: before pruning, after
it, after recovery), the right mask's final graph and a full-size thinning of the left mask (its graph before
and after the same pruning), against the truth (the child's and the parent's axes and radii projected into the
rectified left view; what hides the child's stub past the parent's silhouette: a leaf / apple or a branch, from
the exact mask and the depth map). One cause per fork, the first that holds: the view's edge; a junction within
40 px before pruning and none after (the child's stub or another spur pruned); a junction 40-80 px off (the
child along its parent, or a Y parting late; with what ``fork`` did with it); the child along its parent (its
outline parts from the parent's more than 40 px from the fork: the skeleton's junction lies there); the parent
ending beside the child; a corner (the parent hidden just before or past the fork); the child hidden; the child
not in the mask; a junction only in a full-size skeleton.
"""

from __future__ import annotations

import argparse
import importlib
import linecache
import pickle
import sys
from collections import Counter
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from localize_accuracy import REPO, _seed_range, rectified_points, scene_cache  # noqa: E402

from appliance.calibrate.model import load_calibration  # noqa: E402
from appliance.config import load_config  # noqa: E402
from appliance.localize import Localizer, forkends  # noqa: E402
from appliance.localize import localizer as localizer_mod  # noqa: E402
from appliance.localize.graph import JUNCTION, build_graph  # noqa: E402
from appliance.localize.prune import prune  # noqa: E402
from appliance.localize.radius import radius_at, ridge_radius_map  # noqa: E402
from appliance.localize.skeleton import skeletonize  # noqa: E402
from appliance.synth.evaluate import score_result  # noqa: E402
from appliance.synth.truth import load_truth  # noqa: E402

KEEP = ("xy", "outline", "along", "parents", "child", "child_ok", "d", "agree", "c1", "e1", "c2", "e2", "r_par", "rad")


class ForkTrace:
    """Records of ``ForkPlacing.fork`` per junction node of the pair being localized: ``recs[node]`` a dict of
    the locals ``KEEP`` at its return, ``lines`` (line number, ``agree``) of every line run, ``hidden``,
    ``node_xy``, the child curve's disparity at the place (``d_child``) and every right-outline place found
    (``right``: (base, direction, place or None))."""

    def __init__(self):
        self.recs: dict = {}
        self._rec = None
        self._fork = forkends.ForkPlacing.fork
        self._outline = forkends.ForkPlacing._fork_from_child_outline
        code, trace = self._fork.__code__, self

        def fork(placer, node, final=False, needed=True):
            rec = trace._rec = {"lines": []}

            def local(frame, event, arg):
                if event == "line":
                    rec["lines"].append((frame.f_lineno, frame.f_locals.get("agree")))
                elif event == "return":
                    loc = frame.f_locals
                    rec.update({k: loc[k] for k in KEEP if k in loc})
                    if loc.get("child_ok") and "at" in loc:
                        rec["d_child"] = float(loc["at"](loc["child"]))
                return local

            sys.settrace(lambda frame, event, arg: local if frame.f_code is code and event == "call" else None)
            try:
                return trace._fork(placer, node, final, needed)
            finally:
                sys.settrace(None)
                trace._rec = None
                rec["hidden"] = int(node) in placer.hidden
                rec["node_xy"] = np.array(placer.node_xy[node], float)
                if "xy" in rec or int(node) not in trace.recs:     # (a later call that returned early: the place stands)
                    trace.recs[int(node)] = rec

        def outline(placer, c1, e1, c2, e2, p0, r_par, r_child, mask=None):
            xy = trace._outline(placer, c1, e1, c2, e2, p0, r_par, r_child, mask)
            if mask is not None and trace._rec is not None:
                trace._rec.setdefault("right", []).append((np.array(c1), np.array(e1), None if xy is None else np.array(xy)))
            return xy

        forkends.ForkPlacing.fork = fork
        forkends.ForkPlacing._fork_from_child_outline = outline


class StageTrace:
    """The skeleton stages of each mask ``Localizer._graph`` thins (``calls``: one dict per call, the left mask's
    first: ``skel`` before pruning, ``pruned`` (skeleton, graph) after it, ``final`` the graph after recovery,
    ``radius``) and the rectified coverage of both views (``masks``), by wrapping the names ``localizer``
    calls (nothing copied)."""

    def __init__(self):
        self.calls: list = []
        self.masks = None
        self._prune, self._recover = localizer_mod.prune, localizer_mod.recover
        self._masks = localizer_mod.Localizer._masks
        trace = self

        def prune_(skel, min_length_px, radius_factor=0.0, radius_map=None, max_rounds=20, keep_border=False, **kw):
            out = trace._prune(skel, min_length_px, radius_factor, radius_map, max_rounds, keep_border, **kw)
            trace.calls.append({"skel": skel, "pruned": out, "radius": radius_map})
            return out

        def recover_(graph, cfg, radius, occluder=None):
            g = trace._recover(graph, cfg, radius, occluder)
            trace.calls[-1]["final"] = g
            return g

        def masks_(loc, left, right, mask_left, mask_right, clock):
            out = trace._masks(loc, left, right, mask_left, mask_right, clock)
            trace.masks = out[:2]
            return out

        localizer_mod.prune, localizer_mod.recover = prune_, recover_
        localizer_mod.Localizer._masks = masks_


def _junctions(graph) -> np.ndarray:
    """Full-resolution (x, y) of a graph's junction nodes, (K, 2)."""
    k = np.flatnonzero(graph.node_kind == JUNCTION)
    return graph.to_full(graph.node_yx[k]) if len(k) else np.zeros((0, 2))


def _nearest(pts: np.ndarray, uv: np.ndarray) -> float:
    return float(np.hypot(*(pts - uv).T).min()) if len(pts) else np.inf


def _resample(axis: np.ndarray, radius: np.ndarray, step_mm: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Axis points every ``step_mm`` (arc length from the first vertex, points (N, 3), radii (N,))."""
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(axis, axis=0), axis=1))]
    t = np.arange(0.0, s[-1] + 1e-9, step_mm)
    return t, np.stack([np.interp(t, s, axis[:, i]) for i in range(3)], 1), np.interp(t, s, radius)


JUNCTION_REACH_PX = 40.0     # the tracer's: a junction "of" a fork lies within this of it
STUB_WINDOW_PX = 40.0        # the child's stub looked at: this far (image) past the parent's silhouette


def junction_split(truth, calib, j: int, stages: StageTrace, right_final, thin_pre, thin_post, f_px: float) -> dict:
    """Why true fork ``j`` has no skeleton junction near it: measures from the truth and the masks (a dict).

    Truth: the child's and the parent's axes projected (rectified left view, 1 mm steps; radii px = f r / Z); the
    child's arc ``clear_mm`` (and image distance from the fork ``clear_px``) where its axis leaves the parent's
    silhouette (image distance to the parent's projected axis above both radii); its stub, the samples from there
    to ``STUB_WINDOW_PX`` further: the share visible in the truth (``vis``: on the exact mask with the child's
    depth), hidden behind a leaf / apple (``leaf``: no branch there) or a branch (``branch``: something nearer),
    in the mask used (``in_mask``) and in the coarse block mask the skeleton thins (``in_block``); ``stub_px``,
    its image length from the fork to its first sample not in the mask. The parent's two arms 1.2-2.5 radii
    (+10 px) from the fork, the share seen (``par_out`` past the fork, ``par_in`` before it); the parent's tip's
    distance from the fork (``par_rest_px``) and from the child's outline (``tip_in_child_px``).
    Stages: the nearest junction before pruning (``pre``), after it (``post``), after recovery (``near_px``), in
    the right view's final graph from the fork's right place (``right``), in a full-size thinning's graph before
    and after the same pruning (``thin_pre`` / ``thin_post``), px; the segments pruning removed at a junction
    within ``JUNCTION_REACH_PX``: along the child (``pruned``) or another (``pruned_other``), each (length px,
    the radius px at its junction) or None."""
    tf, br = truth.features, truth.branches
    child, parent = br[int(tf.branch[j])], br[int(tf.parent[j])]
    uv = rectified_points(calib, tf.left_px[j], 0)[0]
    uvr = rectified_points(calib, tf.right_px[j], 1)[0]
    left = stages.calls[0]
    ml = stages.masks[0]
    h, w = ml.shape
    # the parent around the fork (+-250 mm of arc) and the child's first 150 mm
    tp, pp, rp = _resample(parent.axis_mm, parent.radius_mm)
    s0 = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(parent.axis_mm, axis=0), axis=1))][child.parent_vertex]
    keep = np.abs(tp - s0) <= 250
    pp, rp = pp[keep], rp[keep]
    tc, pc, rc = _resample(child.axis_mm, child.radius_mm)
    keep = tc <= 150
    tc, pc, rc = tc[keep], pc[keep], rc[keep]
    xp = rectified_points(calib, truth.rig.project(pp, "left"), 0)
    xc_orig = truth.rig.project(pc, "left")
    xc = rectified_points(calib, xc_orig, 0)
    rpp, rcp = f_px * rp / pp[:, 2], f_px * rc / pc[:, 2]
    dist = np.hypot(*(xc[:, None, :] - xp[None, :, :]).transpose(2, 0, 1))         # (child, parent samples)
    inside = (dist - rpp[None, :]).min(1)                                          # px past the parent's outline
    clear = inside > rcp
    first = int(np.argmax(clear)) if clear.any() else len(tc)
    out = {"clear_mm": float(tc[first]) if first < len(tc) else np.inf, "r_child_px": float(rcp[0]),
           "r_par_px": float(rpp[np.argmin(np.hypot(*(xp - uv).T))]), "child_len_mm": child.length_mm}
    in_view = (xc[:, 0] >= 0) & (xc[:, 0] < w) & (xc[:, 1] >= 0) & (xc[:, 1] < h)
    out["edge_px"] = float(min(uv[0], uv[1], w - 1 - uv[0], h - 1 - uv[1]))
    stub = np.arange(first, len(tc))
    stub = stub[inside[stub] - rcp[stub] <= STUB_WINDOW_PX] if len(stub) else stub
    out["stub_n"] = len(stub)
    out["stub_in_view"] = float(in_view[stub].mean()) if len(stub) else np.nan
    H, W = truth.mask_left.shape
    oi = np.clip(np.round(xc_orig).astype(int), 0, [W - 1, H - 1])
    on = truth.mask_left[oi[:, 1], oi[:, 0]] & in_view
    z = truth.depth_left_mm[oi[:, 1], oi[:, 0]]
    own = on & (np.abs(z - (pc[:, 2] - rc)) <= np.maximum(3.0, rc))
    front = on & ~own & (z < pc[:, 2] - rc)
    ri = np.clip(np.round(xc).astype(int), 0, [w - 1, h - 1])
    in_mask = (ml[ri[:, 1], ri[:, 0]] >= 128) & in_view
    sk = left["skel"]
    bi = np.clip((ri // sk.scale), 0, [sk.mask.shape[1] - 1, sk.mask.shape[0] - 1])
    in_block = (sk.mask[bi[:, 1], bi[:, 0]] > 0) & in_view
    if len(stub):
        out.update(vis=float(own[stub].mean()), leaf=float((~on[stub] & in_view[stub]).mean()),
                   branch=float(front[stub].mean()), in_mask=float(in_mask[stub].mean()),
                   in_block=float(in_block[stub].mean()))
        miss = np.flatnonzero(~in_mask[stub])
        last = stub[miss[0] - 1] if len(miss) and miss[0] > 0 else (stub[-1] if not len(miss) else -1)
        out["stub_px"] = float(inside[last] - rcp[last] + 2 * rcp[last]) if last >= 0 else 0.0
    # the parent's two arms from the fork (on, past it; and before it): the share of the samples 1.2-2.5 parent
    # radii + 10 px (image) from the fork visible in the truth, and the parent's axis length past the fork
    full_tp, full_pp, full_rp = _resample(parent.axis_mm, parent.radius_mm)
    xpa = rectified_points(calib, truth.rig.project(full_pp, "left"), 0)
    da = np.hypot(*(xpa - uv).T)
    r0 = out["r_par_px"]
    ring = (da >= 1.2 * r0) & (da <= 2.5 * r0 + 10)
    pin = (xpa[:, 0] >= 0) & (xpa[:, 0] < w) & (xpa[:, 1] >= 0) & (xpa[:, 1] < h)
    pa = np.clip(np.round(truth.rig.project(full_pp, "left")).astype(int), 0, [W - 1, H - 1])
    zp = truth.depth_left_mm[pa[:, 1], pa[:, 0]]
    pown = (pin & truth.mask_left[pa[:, 1], pa[:, 0]]
            & (np.abs(zp - (full_pp[:, 2] - full_rp)) <= np.maximum(3.0, full_rp)))
    for key, arm in (("par_out", ring & (full_tp > s0)), ("par_in", ring & (full_tp < s0))):
        out[key] = float(pown[arm].mean()) if arm.any() else 0.0
    out["par_rest_px"] = float(np.hypot(*(xpa[-1] - uv))) if len(xpa) else 0.0
    # the image angle between the child (its first 20 mm) and the nearer of the parent's arms (20 mm each way)
    k0 = int(np.argmin(np.abs(full_tp - s0)))
    dirs = [xpa[min(k0 + 20, len(xpa) - 1)] - xpa[k0], xpa[max(k0 - 20, 0)] - xpa[k0]]
    dc0 = xc[min(20, len(xc) - 1)] - xc[0]
    cosines = [abs(float(v @ dc0)) / max(np.hypot(*v) * np.hypot(*dc0), 1e-9) if (v @ dc0) > 0 else 0.0 for v in dirs]
    out["angle_deg"] = float(np.degrees(np.arccos(min(1.0, max(cosines)))))
    # how far the parent's tip lies from the child's projected axis, less both radii (<= 0: inside its outline)
    out["tip_in_child_px"] = float(np.hypot(*(xc - xpa[-1]).T).min() - rcp.max() - f_px * parent.radius_mm[-1]
                                   / full_pp[-1, 2]) if len(xpa) else np.inf
    # stages
    pre = build_graph(sk)
    out["pre"] = _nearest(_junctions(pre), uv)
    post_skel, post = left["pruned"]
    out["post"] = _nearest(_junctions(post), uv)
    out["near_px"] = _nearest(_junctions(left["final"]), uv)
    out["right"] = _nearest(_junctions(right_final), uvr)
    out["thin_pre"] = _nearest(_junctions(thin_pre), uv)
    out["thin_post"] = _nearest(_junctions(thin_post), uv)
    # pre-prune segments removed by pruning with a junction within reach: along the child's first 60 px, or
    # another (the parent's stub cut by a leaf, a bump): (length px, spur limit px at its junction)
    cpts = xc[np.hypot(*(xc - uv).T) <= 60 + rcp]
    out["pruned"] = out["pruned_other"] = None
    for sgi, yx in enumerate(pre.seg_yx):
        if len(yx) == 0 or post_skel.image[yx[:, 0], yx[:, 1]].mean() > 0.5:
            continue
        jn = [n for n in pre.seg_nodes[sgi] if n >= 0 and pre.node_kind[n] == JUNCTION]
        if not jn:
            continue
        jxy = pre.to_full(pre.node_yx[jn[0]])
        if np.hypot(*(jxy[0] - uv)) > JUNCTION_REACH_PX:
            continue
        r_j = float(radius_at(left["radius"], jxy)[0])
        rec = (float(pre.seg_length_px[sgi]), r_j)
        full = pre.to_full(yx)
        dc = np.hypot(*(full[:, None, :] - cpts[None, :, :]).transpose(2, 0, 1)).min(1) if len(cpts) else [np.inf]
        if np.median(dc) <= rcp[0] + 2 * sk.scale:
            out["pruned"] = rec
        elif out["pruned_other"] is None:
            out["pruned_other"] = rec
    out["clear_px"] = float(np.hypot(*(xc[first] - uv))) if first < len(tc) else np.inf
    return out


def no_junction_cause(m: dict) -> str:
    """One cause per fork without a junction (the first that holds, in this order): the view's edge, then the
    skeleton's stages (a junction within reach pruned; one 40-80 px off), then what the truth shows."""
    R = JUNCTION_REACH_PX
    along = m["clear_px"] > R
    if m["edge_px"] < 8 or (m["stub_n"] and m["stub_in_view"] < 0.5):
        return "outside the view (the fork at the edge or the child's stub out of view)"
    if m["pre"] <= R < m["post"]:
        if m["pruned"] is not None:
            return "junction pruned: the child's stub (" + ("hidden past it)" if m.get("vis", 1) < 0.5 else
                                                           "along the parent)" if along else "visible)")
        return "junction pruned: another spur (the parent's stub behind a leaf, a bump)"
    if "far" in m and m["far"][1] <= 5:
        return "a junction 40-80 px off placed the fork within 5 px (" + m["far"][2][:40] + ")"
    corner = min(m["par_out"], m["par_in"]) < 0.3 and m.get("vis", 0) >= 0.3 and not along
    if corner:
        return ("a corner: the parent ends at the fork" if m["par_rest_px"] < 2.5 * m["r_par_px"] + 10 else
                "a corner: the parent hidden " + ("past" if m["par_out"] < m["par_in"] else "before") + " the fork")
    if m["near_px"] <= 2 * R:
        return "junction 40-80 px off: " + ("the child along its parent" if along else "a Y parting late")
    if along:
        if m["par_rest_px"] < m["clear_px"] + m["r_par_px"] and m["tip_in_child_px"] <= 2:
            return "the parent ends beside the child (its end absorbed in the child's outline)"
        return "child along its parent (outlines part > 40 px from the fork), no junction within 80 px" + (
            "; its stub hidden past the parting" if m.get("vis", 0) < 0.3 else "")
    if m.get("vis", 0) < 0.3:
        return ("child hidden: behind a branch" if m.get("branch", 0) >= m.get("leaf", 0)
                else "child hidden: behind a leaf / apple")
    if m.get("in_mask", 0) < 0.5:
        return "child not in the mask (thin / lost by the segmenter)"
    if m.get("in_block", 0) < 0.5:
        return "child lost by the coarse block mask"
    if m["thin_pre"] <= R:
        return "junction only in a full-size skeleton"
    return "other"


def _extra_graphs(loc, stages: StageTrace) -> tuple:
    """The right mask's final graph (the localizer's own ``_graph``), and a full-size thinning of the left mask
    before and after the same pruning: the graphs ``junction_split`` compares."""
    c = loc.cfg
    ml, mr = stages.masks
    n = len(stages.calls)
    right = loc._graph(mr, None, localizer_mod._Clock())[0]
    del stages.calls[n:]
    skel = skeletonize(ml, "thinning", level=127)
    radius = ridge_radius_map(skel.mask)
    _, post = prune(skel, c.prune.min_length_px, c.prune.radius_factor, radius, keep_border=c.prune.keep_border_spurs)
    return right, build_graph(skel), post


def _fmt(m: dict) -> str:
    """One missed fork's measures (``junction_split``), short."""
    pr = "" if m["pruned"] is None else f" child spur pruned {m['pruned'][0]:.0f} px (r {m['pruned'][1]:.1f});"
    if m["pruned_other"] is not None:
        pr += f" other spur pruned {m['pruned_other'][0]:.0f} px (r {m['pruned_other'][1]:.1f});"
    return (f"clear at {m['clear_mm']:.0f} mm / {m['clear_px']:.0f} px, r child/parent {m['r_child_px']:.1f}/"
            f"{m['r_par_px']:.1f} px, angle {m['angle_deg']:.0f} deg, stub "
            f"vis {m.get('vis', np.nan):.2f} (leaf {m.get('leaf', np.nan):.2f}, branch {m.get('branch', np.nan):.2f}),"
            f" in mask {m.get('in_mask', np.nan):.2f}, block {m.get('in_block', np.nan):.2f}, "
            f"{m.get('stub_px', np.nan):.0f} px;{pr} junction pre {m['pre']:.0f}, post {m['post']:.0f}, final "
            f"{m['near_px']:.0f}, right {m['right']:.0f}, thin {m['thin_pre']:.0f}/{m['thin_post']:.0f} px, "
            f"edge {m['edge_px']:.0f}, parent arms seen out/in {m['par_out']:.2f}/{m['par_in']:.2f}, "
            f"its end {m['par_rest_px']:.0f} px off" + ("" if "far" not in m else
                                          f"; the junction {m['far'][0]:.0f} px off placed {m['far'][1]:.0f} px off, "
                                          f"{m['far'][2]}"))


def false_fork(truth, res, fid: int, found: set, f_px: float) -> tuple[str, str]:
    """Where false fork ``fid`` (a reported fork matched to no true one) lies against the truth, original left
    image: (class, details). Each true branch's axis (1 mm steps) projected; a branch counts as under the fork if
    its axis passes within its own image radius + 5 px; its depth there against the fork's. Classes, the first
    that holds: ``placed off`` (a true fork within 40 px, missed: one false and one missed), ``second place of a
    found fork`` (within 40 px, found), ``tip on a branch`` (a true tip within 40 px and another branch under
    it), ``crossing`` (two or more branches under it, no fork or tip near: ``at one depth`` if their depths
    there differ by less than the sum of their radii + 5 mm), ``on one branch`` (a bend, a leaf's edge),
    ``off the axes``."""
    f = next(q for q in res.features if q.id == fid)
    q = np.asarray(f.left_px, float)
    tf = truth.features
    def nearest(kind):
        k = np.flatnonzero((tf.kind == kind) & tf.visible_left)
        if not len(k):
            return np.inf, -1
        dd = np.hypot(*(tf.left_px[k] - q).T)
        return float(dd.min()), int(k[dd.argmin()])
    d_fork, j_fork = nearest("bifurcation")
    d_tip, j_tip = nearest("endpoint")
    under = []
    for b, br in enumerate(truth.branches):
        _, pts, rr = _resample(np.asarray(br.axis_mm, float), np.asarray(br.radius_mm, float))
        px = truth.rig.project(pts, "left")
        dd = np.hypot(*(px - q).T)
        i = int(dd.argmin())
        r_px = f_px * rr[i] / pts[i, 2]
        if dd[i] <= r_px + 5.0:
            under.append((b, float(dd[i]), float(pts[i, 2] - f.xyz_mm[2]), float(rr[i]), float(r_px)))
    det = (f"fork {d_fork:.0f} px (T{j_fork}{' found' if j_fork in found else ''}), tip {d_tip:.0f} px (T{j_tip}); "
           f"under it: " + (", ".join(f"B{b} {dd:.0f} px off axis (r {rp:.0f} px), dZ {dz:+.1f} mm"
                                      for b, dd, dz, _, rp in under) or "none"))
    if d_fork <= 40 and j_fork not in found:
        return f"placed off ({'5-15' if d_fork <= 15 else '15-40'} px)", det
    if d_fork <= 40:
        return "second place of a found fork", det
    if len(under) >= 2 and d_tip <= 40:
        return "tip on a branch", det
    if len(under) >= 2:
        zs = sorted(under, key=lambda u: u[1])[:2]
        one = abs(zs[0][2] - zs[1][2]) < zs[0][3] + zs[1][3] + 5.0
        return f"crossing ({'at one depth' if one else 'apart in depth'})", det
    if under:
        return "on one branch", det
    return "off the axes", det


def placed_off(calib, truth, res, fid: int, recs: dict) -> str:
    """How false fork ``fid``, placed off a true fork, lies against it (rectified left view): the junction whose
    place it is, the offset along the parent's line (``+``: towards the child's outward side) and across it
    (``+``: towards the child), the child's angle to the parent, the junction's distance from the place."""
    f = next(q for q in res.features if q.id == fid)
    q = rectified_points(calib, np.asarray(f.left_px, float), 0)[0]
    tf = truth.features
    k = np.flatnonzero(tf.kind == "bifurcation")
    t = rectified_points(calib, tf.left_px[k], 0)
    uv = t[np.hypot(*(t - q).T).argmin()]
    placed = [(np.hypot(*(rec["xy"] - q)), node, rec) for node, rec in recs.items()
              if "xy" in rec and not rec["hidden"]]
    if not placed:
        return ""
    dist, node, rec = min(placed, key=lambda x: x[0])
    e1, e2 = rec["e1"], rec["e2"]
    out = e2 if np.dot(rec["c2"] - rec["xy"], e2) >= 0 else -e2
    along_dir = e1 if np.dot(out, e1) >= 0 else -e1
    n = np.array([-e1[1], e1[0]])
    n = n if np.dot(out, n) >= 0 else -n
    v = rec["xy"] - uv
    ang = np.degrees(np.arcsin(min(1.0, abs(e1[0] * e2[1] - e1[1] * e2[0]))))
    return (f"; node {node} ({dist:.1f} px from it), {'along_fork' if rec.get('along') else 'outline'} place "
            f"{np.dot(v, along_dir):+.1f} px along, {np.dot(v, n):+.1f} across the parent, child at {ang:.0f} deg, "
            f"radii {rec['r_par']:.1f} / {rec['rad'][rec['child']]:.1f} px, junction "
            f"{np.hypot(*(rec['node_xy'] - rec['xy'])):.0f} px from the place")


def cause(rec: dict) -> str:
    """What ``fork`` did with one junction (see the module's doc)."""
    if "xy" not in rec:
        return "not placed"
    if not rec["hidden"]:
        return "reported"
    if not rec.get("parents"):
        return "no parent piece"
    if rec.get("outline") is None:
        return "no child outline"
    was, prev = False, None
    for ln, a in rec["lines"]:
        a = None if a is None else bool(a)
        if was and prev is not None and prev[1] and not a:
            return f"withheld at {prev[0]}: {linecache.getline(forkends.__file__, prev[0]).strip()[:70]}"
        was = was or bool(a)
        prev = (ln, a)
    return "withheld (after the checks)" if was else "child not confirmed"


def scene_list(extra: int, seeds) -> list:
    """(name, left, right, truth json) of the cached scenes only (fixtures unless ``seeds``)."""
    fx, cache = REPO / "fixtures" / "scenes", scene_cache(2)
    out = [] if seeds is not None else [(f"fixture {t.stem.split('_')[1]}", fx / f"left_{t.stem.split('_')[1]}.png",
                                          fx / f"right_{t.stem.split('_')[1]}.png", t)
                                         for t in sorted(fx.glob("truth_*.json"))]
    for s in (seeds if seeds is not None else range(100, 100 + extra)):
        out.append((f"seed {s}", cache / f"left_{s}.png", cache / f"right_{s}.png", cache / f"truth_{s}.json"))
    return out



def improved_localizer(sets: list[str]) -> Localizer:
    """The improved localizer on the fixtures' rig, after ``--set MODULE.NAME=VALUE`` options (``sets``) set
    those module constants of ``appliance.localize`` (the value a Python expression)."""
    for kv in sets:
        key, value = kv.split("=", 1)
        mod, name = key.rsplit(".", 1)
        setattr(importlib.import_module(f"appliance.localize.{mod}"), name, eval(value))
    return Localizer(load_calibration(REPO / "fixtures" / "rig.yaml"), load_config().localize, "improved")

def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extra", type=int, default=56)
    ap.add_argument("--seeds", metavar="A-B", type=_seed_range)
    ap.add_argument("--masks", choices=["true", "colour"], default="true")
    ap.add_argument("--set", action="append", default=[], metavar="MODULE.NAME=VALUE")
    ap.add_argument("--pickle", type=Path)
    ap.add_argument("-v", action="store_true")
    ap.add_argument("--false", action="store_true", help="also class every false fork (false_fork)")
    ap.add_argument("--junctions", action="store_true",
                    help="split the forks without a junction by cause (junction_split; slower: also skeletons of "
                         "the right mask and a full-size thinning)")
    a = ap.parse_args()
    loc = improved_localizer(a.set)
    calib = loc.calib
    trace = ForkTrace()
    stages = StageTrace() if a.junctions else None
    split, split_rows = Counter(), []
    counts, n_seen, n_found, n_false, saved = Counter(), 0, 0, 0, []
    false_counts = Counter()
    for name, lp, rp, tp in scene_list(a.extra, a.seeds):
        if not (tp.exists() and lp.exists() and rp.exists() and tp.with_suffix(".npz").exists()):
            print(f"{name}: not rendered, skipped")
            continue
        truth = load_truth(tp)
        kw = dict(zip(("mask_left", "mask_right"), truth.exact_masks(soft=False))) if a.masks == "true" else {}
        trace.recs = {}
        if stages is not None:
            stages.calls = []
        res = loc.localize(cv2.imread(str(lp)), cv2.imread(str(rp)), **kw)
        extra = None
        tf = truth.features
        rows = [r for r in score_result(res, truth, name=name).rows if r.kind == "bifurcation"]
        n_false += sum(r.truth_index < 0 for r in rows)
        if a.false:
            found = {r.truth_index for r in rows if r.truth_index >= 0 and r.result_id >= 0}
            for r in rows:
                if r.truth_index < 0:
                    why, det = false_fork(truth, res, r.result_id, found, float(calib.f_px))
                    if why.startswith("placed off"):
                        det += placed_off(calib, truth, res, r.result_id, trace.recs)
                    false_counts[why] += 1
                    print(f"{name} false fork {r.result_id}: {why}; {det}")
        for r in rows:
            j = r.truth_index
            if j < 0 or not (tf.visible_left[j] and tf.visible_right[j]):
                continue
            n_seen += 1
            if r.result_id >= 0:
                n_found += 1
                continue
            uv = rectified_points(calib, tf.left_px[j], 0)[0]
            d_true = float(uv[0] - rectified_points(calib, tf.right_px[j], 1)[0][0])
            near = [(min(np.hypot(*(rec["node_xy"] - uv)), np.hypot(*(rec["xy"] - uv)) if "xy" in rec else np.inf),
                     node, rec) for node, rec in trace.recs.items() if np.hypot(*(rec["node_xy"] - uv)) < 40]
            if not near:
                counts["no junction"] += 1
                if stages is not None:
                    if extra is None:
                        extra = _extra_graphs(loc, stages)
                    m = junction_split(truth, calib, j, stages, *extra, float(calib.f_px))
                    far = [(np.hypot(*(rec["node_xy"] - uv)), rec) for rec in trace.recs.values()]
                    far = min(far, key=lambda q: q[0]) if far else (np.inf, None)
                    if far[0] <= 2 * JUNCTION_REACH_PX:      # what ``fork`` did with the junction 40-80 px off
                        m["far"] = (float(far[0]), float(np.hypot(*(far[1]["xy"] - uv))) if "xy" in far[1] else np.inf,
                                    cause(far[1]))
                    why = no_junction_cause(m)
                    split[why] += 1
                    split_rows.append((name, j, why, m))
                    if a.v:
                        print(f"{name} T{j}: no junction: {why}; {_fmt(m)}")
                elif a.v:
                    print(f"{name} T{j}: no junction")
                continue
            _, node, rec = min(near, key=lambda q: q[0])
            off = np.hypot(*(rec["xy"] - uv)) if "xy" in rec else np.inf
            band = "within 5" if off <= 5 else "5-40" if off <= 40 else ">40"
            why = cause(rec)
            counts[f"{band}: {why}"] += 1
            saved.append((name, j, uv, d_true, node, rec))
            if a.v and "d" in rec:
                e1, e2 = rec["e1"], rec["e2"]
                ang = np.degrees(np.arcsin(min(1.0, abs(e1[0] * e2[1] - e1[1] * e2[0]))))
                row = np.degrees(np.arcsin(min(1.0, abs(e2[1]))))
                right = " ".join("none" if p is None else f"{(p - c) @ e:+.2f}" for c, e, p in rec.get("right", []))
                print(f"{name} T{j}: node {node}, {off:.1f} px off, {why}; d {rec['d']:.2f} px ({rec['d'] - d_true:+.2f} "
                      f"from the truth), child curve {rec.get('d_child', np.nan) - rec['d']:+.2f}, child at {ang:.0f} deg "
                      f"to the parent, {row:.0f} deg to the rows, radii {rec['r_par']:.1f} / {rec['rad'][rec['child']]:.1f} px"
                      + (f", right outline along {right}" if right else ""))
            elif a.v:
                print(f"{name} T{j}: node {node}, {why}")
    print(f"\nforks seen in both views {n_seen}, found {n_found}, missed {n_seen - n_found}; false forks {n_false}")
    for k, v in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])):
        print(f"{v:4d}  {k}")
    if false_counts:
        print("\nfalse forks, by where they lie:")
        for k, v in sorted(false_counts.items(), key=lambda kv: (-kv[1], kv[0])):
            print(f"{v:4d}  {k}")
    if split:
        print("\nno junction, by cause:")
        for k, v in sorted(split.items(), key=lambda kv: (-kv[1], kv[0])):
            print(f"{v:4d}  {k}: " + " ".join(f"{n.split()[-1]}T{j}" for n, j, w, _ in split_rows if w == k))
        rows = [m for *_, m in split_rows]
        print(f"  with a junction in the right view: {sum(m['right'] <= JUNCTION_REACH_PX for m in rows)}; in a "
              f"full-size thinning before / after pruning: {sum(m['thin_pre'] <= JUNCTION_REACH_PX for m in rows)} / "
              f"{sum(m['thin_post'] <= JUNCTION_REACH_PX for m in rows)}; before pruning: "
              f"{sum(m['pre'] <= JUNCTION_REACH_PX for m in rows)}")
    if a.pickle:
        a.pickle.write_bytes(pickle.dumps({"saved": saved, "split": split_rows}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
