"""The features of one depth band whose depth error is in the band's tail, with the rule that set each one's disparity.

    python benchmarks/band_tail.py [--extra 56 | --seeds A-B] [--masks true|colour|both] [--soft-truth]
                                   [--band 1000-1250] [--over MM] [--pickle OUT] [--set MODULE.NAME=VALUE ...]

Scenes as ``localize_accuracy.py`` (fixtures plus ``--extra`` seeds 100.., or ``--seeds A-B``), read from the cache
only (a scene not rendered is skipped, never rendered). Each pair runs the improved localizer with
``ForkPlacing.fork`` and ``TipPlacing._tip_place`` traced (``sys.settrace`` on those frames only: the lines they
ran and their locals at return; nothing of them is copied, so the labels below follow the code as long as the
source lines they look for stay). Every matched feature whose true depth lies in the band is scored; those with
|dZ| over the band's p95 (or over ``--over`` mm, default 1.5) are printed one a line:

- kind, masks, dZ (mm), disparity error (px), the feature's radius (px), the parent's slope (``steep`` pieces are
  matched by their row crossings, ``flat`` ones by bark texture);
- forks: the rule that set the disparity (``mean2`` / ``one`` the parent sides' mean / lone side, ``median3``,
  ``known``, ``weighted``, ``bent`` (forkdisp.weigh_bent_sides), ``flat-outline``, ``lone-flat-outvoted``,
  ``flat-pick-mean3``, ``flat-pick-one``,
  ``carried-flat-outvoted``, ``sides-outline``, ``lone-carried-median``, ``child``; ``+axis`` when moved onto
  the parent's axis, ``+later`` when changed after ``fork`` returned, ``hidden-fork`` for a hidden end placed at
  its crossing with another piece by ``ForkPlacing.hidden_fork``: the parent piece's curve there and how far past
  its span, the child's curve and how far (px) it was carried from its own span)
  and each side's
  source (``steep-read`` its crossings next to the fork, ``flat-tex`` its texture there, ``-span`` / ``-carried``
  its curve inside its fitted span / carried past it, ``(tex agrees)`` its texture read there within 0.25 px of
  it) with its error against the truth (px), the child's curve and its right outline;
- tips: ``steep-cap`` (the cap's rows), ``steep-curve``, ``flat-runend`` (the right run's end), ``flat-texture``,
  ``merged-right-cap``, ``flat-stub``, with the piece's origin (``dense``, ``caps`` stub, ``flatcap``) and its
  curve's error there.

Then the counts by kind / slope / rule (the table of causes). ``--soft-truth``: the exact masks as the renderer's
soft coverage (as ``localize_accuracy.py --soft-truth``).
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import pickle
import sys
from collections import Counter
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fork_misses import scene_list  # noqa: E402
from localize_accuracy import REPO, _seed_range  # noqa: E402

from appliance.calibrate.model import load_calibration  # noqa: E402
from appliance.config import load_config  # noqa: E402
from appliance.localize import Localizer, dense, forkends, localizer, tipends  # noqa: E402
from appliance.localize.forkdisp import side_disparity_near  # noqa: E402
from appliance.synth.evaluate import score_result  # noqa: E402
from appliance.synth.truth import load_truth  # noqa: E402

FORK_RULES = {          # a source line's start -> the rule it applies (the last one run names the fork's rule)
    "d_par = [float(sorted([*d_par, at(child)])[1])]": "median3",
    "d = float(at(child))": "child",
    "d, agree = 0.5 * (min(sides, key=": "sides-outline",
    "d, agree = float((at(next(s for s in parents if s in flat_read))": "carried-flat-outvoted",
    "d, agree = 0.5 * (d_one + d_out), True": "flat-pick-one",
    "d, agree = float((d_par[0] + d_par[1] + d_out) / 3.0), True": "flat-pick-mean3",
    "d, agree = float((d + at(child) + d_out) / 3.0), True": "lone-flat-outvoted",
    "d, agree = d_out, True": "flat-outline",
    "self.uvd[node][2] = d_known": "known",
    "self.uvd[node][2] = weigh_sides(": "weighted",
    "self.uvd[node][2] = weigh_bent_sides(": "bent",
    "self.uvd[node][2] = lone_carried_median(": "lone-carried-median",
}
AXIS_LINE = "self.uvd[node][2] -= centre_bias_px("
TIP_RULES = {
    "self.uvd[node][2] = d_end": "flat-runend",
    "d_end = self.uvd[node][2]": "flat-stub",
    "uvd = right_cap_tip(": "merged-right-cap",
    "self.uvd[node][2] = d_cap": "steep-cap",
}


def _line_map(func, table: dict) -> dict:
    """{line number: label} of the lines of ``func``'s source starting with a key of ``table``."""
    src, first = inspect.getsourcelines(func)
    out = {}
    for k, line in enumerate(src):
        for start, label in table.items():
            if line.strip().startswith(start):
                out[first + k] = label
    return out


class Trace:
    """Per localized pair: ``forks[node]`` / ``tips[node]`` records of the final call, the EndPlacer ``placer``,
    the features handed to the check and its verdicts, the segments of stub curves (``origin``)."""

    def __init__(self):
        self.fork_lines = _line_map(forkends.ForkPlacing.fork, FORK_RULES)
        self.axis_lines = _line_map(forkends.ForkPlacing.fork, {AXIS_LINE: "axis"})
        self.tip_lines = _line_map(tipends.TipPlacing._tip_place, TIP_RULES)
        self.reset()
        trace = self
        self._wrap_traced(forkends.ForkPlacing, "fork", self._fork_return)
        self._wrap_traced(tipends.TipPlacing, "_tip_place", self._tip_return)
        hidden_fork = forkends.ForkPlacing.hidden_fork

        def traced_hidden_fork(placer, node, *a, **k):
            ok = hidden_fork(placer, node, *a, **k)
            if ok:
                trace._hidden_fork_return(placer, int(node))
            return ok
        forkends.ForkPlacing.hidden_fork = traced_hidden_fork
        placer_cls = dense.EndPlacer

        def placer(*a, **k):
            trace.placer = placer_cls(*a, **k)
            return trace.placer
        dense.EndPlacer = placer
        for name, tag in (("cap_curves", "caps"), ("flat_cap_curves", "flatcap")):
            f = getattr(dense, name)

            def wrapped(*a, _f=f, _tag=tag, **k):
                out = _f(*a, **k)
                trace.origin.update({int(s): _tag for s in out})
                return out
            setattr(dense, name, wrapped)
        check = localizer.check_features

        def checked(features, *a, **k):
            out = check(features, *a, **k)
            trace.checked = (list(features), list(out))
            return out
        localizer.check_features = checked

    def reset(self):
        self.forks, self.tips, self.origin, self.placer, self.checked = {}, {}, {}, None, None
        self.hidden_forks = {}

    def _hidden_fork_return(self, b, node):
        """A hidden end placed at a crossing (``ForkPlacing.hidden_fork``): the parent piece whose curve gave
        its disparity, the child's curve there and how far (px) the child's fitted span was carried to it."""
        u, v, d = (float(x) for x in b.uvd[node])
        xy = np.array([u, v])
        child = next(s for s in b.incident[node] if s in b.curves)
        cc = b.curves[child]
        parent, d_curve = None, None
        for s, c in b.curves.items():
            if s != child and abs(float(forkends._d_at(c, u, v)) - d) < 1e-9:
                parent = int(s)
        if parent is None:      # (read from the parent's crossings, forkhidden.py: the piece whose line passes there)
            gaps = {int(s): float(np.hypot(*(c.uv_at(np.array([forkends._t_at(c, xy)]))[0] - xy)))
                    for s, c in b.curves.items() if s != child}
            if gaps:
                parent = min(gaps, key=gaps.get)
                d_curve = float(forkends._d_at(b.curves[parent], u, v))
        ends = cc.uv_at(np.array(cc.t_range, float))
        self.hidden_forks[node] = dict(parent=parent, d=d, d_curve=d_curve, d_child=float(forkends._d_at(cc, u, v)),
                                       child=int(child),
                                       carried_px=float(np.hypot(*(ends - xy).T).min()),
                                       parent_past_px=None if parent is None else float(b._carried_px(parent, xy)))

    def _wrap_traced(self, cls, name, on_return):
        f = getattr(cls, name)
        code = f.__code__

        def traced(placer, node, *a, **k):
            lines = []

            def local(frame, event, arg):
                if event == "line":
                    lines.append(frame.f_lineno)
                elif event == "return":
                    on_return(placer, int(node), frame.f_locals, lines)
                return local
            prev = sys.gettrace()
            sys.settrace(lambda frame, event, arg: local if frame.f_code is code and event == "call" else None)
            try:
                return f(placer, node, *a, **k)
            finally:
                sys.settrace(prev)
        setattr(cls, name, traced)

    def _fork_return(self, b, node, loc, lines):
        if "xy" not in loc or "agree" not in loc:
            return
        xy, parents = loc["xy"], loc.get("parents") or []
        xu, xv = float(xy[0]), float(xy[1])
        side_near = loc.get("side_near") or {}
        sides = []
        for s in parents:
            c = b.curves[s]
            src = ("steep-" if c.by_row else "flat-") + (
                ("read" if c.by_row else "tex") if s in side_near else "span" if b._carried_px(s, xy) <= 0 else "carried")
            if s in (loc.get("flat_read") or ()) and s not in side_near:
                src += "(tex agrees)"           # (its texture read there, within FLAT_NEAR_MIN_PX of the curve)
            curve_d = float(forkends._d_at(c, xu, xv))
            sn = side_near.get(s)
            sides.append(dict(seg=int(s), src=src, d=sn.d_px if sn is not None else curve_d, d_curve=curve_d,
                              nearest_px=None if sn is None else float(sn.nearest_px),
                              n_rows=None if sn is None else int(getattr(sn, "n_rows", -1)),
                              slope=None if sn is None else float(getattr(sn, "slope", np.nan)),
                              carried_px=float(b._carried_px(s, xy)), radius_px=float(c.radius_px),
                              t_range=tuple(float(t) for t in c.t_range), by_row=bool(c.by_row)))
        rule = None
        for ln in lines:
            if ln in self.fork_lines:
                rule = self.fork_lines[ln]
        if rule is None:
            rule = {0: "none", 1: "one", 2: "mean2"}[len(parents)]
        child = loc.get("child")
        d_child = float(forkends._d_at(b.curves[child], xu, xv)) if loc.get("child_ok") else None
        child_read = None       # (diagnostic: the child's own crossings nearest the fork, read as a side's)
        if child is not None and child in b.curves and b.curves[child].by_row:
            cr = side_disparity_near(b.curves[child], b.runs_l, b.runs_r, forkends._t_at(b.curves[child], xy),
                                     f_px=b.sm.f_px, cx_px=b.sm.cx_px, offset_px=b.sm.offset_px)
            if cr is not None:
                child_read = dict(d=float(cr.d_px), nearest_px=float(cr.nearest_px), n_rows=int(cr.n_rows),
                                  mad=float(cr.mad_px), gap_px=int(cr.gap_px))
        self.forks[node] = dict(rule=rule, axis=any(ln in self.axis_lines for ln in lines), sides=sides,
                                d_child=d_child, d_out=loc.get("d_out"), d=float(b.uvd[node][2]) if node in b.uvd else None,
                                r_par=float(loc.get("r_par", np.nan)), hidden=node in b.hidden,
                                child_carried=None if d_child is None else float(b._carried_px(child, xy)),
                                child_read=child_read, xy=(xu, xv), child_radius=None if child not in b.curves
                                else float(b.curves[child].radius_px))

    def _tip_return(self, b, node, loc, lines):
        c = loc.get("c")
        if c is None:
            return
        rule = None
        for ln in lines:
            if ln in self.tip_lines:
                rule = self.tip_lines[ln]
        if rule is None:
            rule = "steep-curve" if c.by_row else "flat-texture"
        uvd = b.uvd.get(node)
        d_curve = None if uvd is None else float(c.d_at(uvd[1] if c.by_row else uvd[0])[0])
        self.tips[node] = dict(rule=rule, steep=bool(c.by_row), seg=int(c.segment), radius_px=float(c.radius_px),
                               d=None if uvd is None else float(uvd[2]), d_curve=d_curve,
                               d_end=None if loc.get("d_end") is None else float(loc["d_end"]))


def describe(tr: Trace, node: int, kind: str, d_final: float, d_err: float) -> tuple[str, str, str]:
    """(slope, rule, details) of the feature of graph node ``node`` (``d_err``: its signed disparity error, px)."""
    d_true = d_final - d_err
    if kind == "bifurcation" and node in tr.forks:
        f = tr.forks[node]
        slope = "+".join(sorted({"steep" if s["src"].startswith("steep") else "flat" for s in f["sides"]})) or "-"
        rule = f["rule"] + ("+axis" if f["axis"] else "") + ("+later" if f["d"] is not None and abs(f["d"] - d_final) > 1e-6 else "")
        parts = [f"{s['src']} {s['d'] - d_true:+.2f}" + (f" (curve {s['d_curve'] - d_true:+.2f})" if s["d_curve"] != s["d"] else "")
                 + (f" @{s['nearest_px']:.0f}px" + (f" slope {s['slope']:+.2f}" if s["by_row"] else "")
                    if s["nearest_px"] is not None else f" carried {s['carried_px']:.0f}px")
                 for s in f["sides"]]
        if f["d_child"] is not None:
            parts.append(f"child {f['d_child'] - d_true:+.2f} carried {f['child_carried']:.0f}px")
        if f.get("child_read") is not None:
            cr = f["child_read"]
            parts.append(f"child-read {cr['d'] - d_true:+.2f} @{cr['nearest_px']:.0f}px n{cr['n_rows']}")
        if f["d_out"] is not None:
            parts.append(f"outline {f['d_out'] - d_true:+.2f}")
        return slope, rule, "; ".join(parts) + f"; r_par {f['r_par']:.1f}px"
    if node in tr.hidden_forks:            # (its disparity: the parent's curve at the crossing, not the tip's rule)
        h = tr.hidden_forks[node]
        slope = ("steep" if tr.placer.curves[h["parent"]].by_row else "flat") if h["parent"] is not None else "-"
        past = "" if h["parent_past_px"] is None else f" ({h['parent_past_px']:.1f} rows/cols past its span)"
        read = "" if h["d_curve"] is None else f" read (its curve {h['d_curve'] - d_true:+.2f})"
        return slope, "hidden-fork", (f"parent piece {h['parent']} {h['d'] - d_true:+.2f}{read}{past}; child {h['child']} "
                                      f"{h['d_child'] - d_true:+.2f} carried {h['carried_px']:.0f}px")
    if node in tr.tips:
        t = tr.tips[node]
        det = f"piece {tr.origin.get(t['seg'], 'dense')}, r {t['radius_px']:.1f}px"
        if t["d_curve"] is not None:
            det += f"; curve {t['d_curve'] - d_true:+.2f}"
        return ("steep" if t["steep"] else "flat"), ("hidden-fork:" if kind == "bifurcation" else "") + t["rule"], det
    return "-", "hidden-fork" if node < dense.STUB_NODE else "stub-tip", ""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extra", type=int, default=56)
    ap.add_argument("--seeds", metavar="A-B", type=_seed_range)
    ap.add_argument("--masks", choices=["true", "colour", "both"], default="both")
    ap.add_argument("--band", default="1000-1250")
    ap.add_argument("--over", type=float, default=1.5, help="also list |dZ| over this (mm)")
    ap.add_argument("--set", action="append", default=[], metavar="MODULE.NAME=VALUE")
    ap.add_argument("--pickle", type=Path)
    ap.add_argument("--soft-truth", action="store_true",
                    help="exact masks as the renderer's soft coverage of each pixel (as localize_accuracy.py)")
    a = ap.parse_args()
    for kv in a.set:
        key, value = kv.split("=", 1)
        mod, name = key.rsplit(".", 1)
        setattr(importlib.import_module(f"appliance.localize.{mod}"), name, eval(value))
    lo, hi = (float(x) for x in a.band.split("-"))
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    loc = Localizer(calib, load_config().localize, "improved")
    tr = Trace()
    recs = []
    masks = ["true", "colour"] if a.masks == "both" else [a.masks]
    for name, lp, rp, tp in scene_list(a.extra, a.seeds):
        if not (tp.exists() and lp.exists() and rp.exists() and tp.with_suffix(".npz").exists()):
            print(f"{name}: not rendered, skipped")
            continue
        truth = load_truth(tp)
        left, right = cv2.imread(str(lp)), cv2.imread(str(rp))
        for m in masks:
            kw = dict(zip(("mask_left", "mask_right"), truth.exact_masks(soft=a.soft_truth))) if m == "true" else {}
            tr.reset()
            res = loc.localize(left, right, **kw)
            feats = [f for f, k in zip(*tr.checked) if not k.withheld] if tr.checked else []
            for r in score_result(res, truth, name=name).rows:
                if r.truth_index < 0 or r.result_id < 0 or not lo <= r.z_true_mm < hi:
                    continue
                ft = feats[r.result_id]
                d_err = -float(np.sign(r.dz_mm)) * r.disparity_err_px        # (signed: the evaluator's is |.|)
                slope, rule, det = describe(tr, ft.node, r.kind, ft.d, d_err)
                recs.append(dict(scene=name, masks=m, t=r.truth_index, kind=r.kind, z=r.z_true_mm, dz=r.dz_mm,
                                 derr=d_err, radius_px=ft.radius_px, slope=slope, rule=rule, det=det,
                                 node=ft.node, d=ft.d, fork=tr.forks.get(ft.node) if r.kind == "bifurcation" else None,
                                 tip=tr.tips.get(ft.node)))
    for m in masks:
        rs = [r for r in recs if r["masks"] == m]
        if not rs:
            continue
        p95 = float(np.percentile(np.abs([r["dz"] for r in rs]), 95))
        tail = sorted((r for r in rs if abs(r["dz"]) > min(p95, a.over)), key=lambda r: -abs(r["dz"]))
        print(f"\n== {m} masks: band {a.band} mm, n {len(rs)}, p95 |dZ| {p95:.2f} mm; {len(tail)} over "
              f"{min(p95, a.over):.2f} mm ({sum(abs(r['dz']) > p95 for r in rs)} over the p95)")
        for r in tail:
            print(f"{r['scene']:>11} T{r['t']:<3}{r['kind'][:4]:>5} {r['dz']:+6.2f} mm {r['derr']:+.2f} px r {r['radius_px']:4.1f}"
                  f" {r['slope']:<11}{r['rule']:<24}{r['det']}")
        for key in ("kind", "slope", "rule"):
            c_all, c_tail = Counter(r[key] for r in rs), Counter(r[key] for r in tail)
            print(f"  by {key}: " + ", ".join(f"{k} {c_tail[k]}/{c_all[k]}" for k in sorted(c_all, key=lambda k: -c_tail[k])))
    if a.pickle:
        a.pickle.write_bytes(pickle.dumps(recs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
