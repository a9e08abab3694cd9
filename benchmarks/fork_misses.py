"""Every true fork the improved localizer misses, by cause (issue 5's fork recall), from a trace of ForkPlacing.fork.

    python benchmarks/fork_misses.py [--extra N | --seeds A-B] [--masks true|colour] [-v] [--pickle OUT]
                                     [--set MODULE.NAME=VALUE ...]

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
from appliance.synth.evaluate import score_result  # noqa: E402
from appliance.synth.truth import load_truth  # noqa: E402

KEEP = ("xy", "outline", "parents", "child", "child_ok", "d", "agree", "c1", "e1", "c2", "e2", "r_par", "rad")


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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extra", type=int, default=56)
    ap.add_argument("--seeds", metavar="A-B", type=_seed_range)
    ap.add_argument("--masks", choices=["true", "colour"], default="true")
    ap.add_argument("--set", action="append", default=[], metavar="MODULE.NAME=VALUE")
    ap.add_argument("--pickle", type=Path)
    ap.add_argument("-v", action="store_true")
    a = ap.parse_args()
    for kv in a.set:
        key, value = kv.split("=", 1)
        mod, name = key.rsplit(".", 1)
        setattr(importlib.import_module(f"appliance.localize.{mod}"), name, eval(value))
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    loc = Localizer(calib, load_config().localize, "improved")
    trace = ForkTrace()
    counts, n_seen, n_found, n_false, saved = Counter(), 0, 0, 0, []
    for name, lp, rp, tp in scene_list(a.extra, a.seeds):
        if not (tp.exists() and lp.exists() and rp.exists() and tp.with_suffix(".npz").exists()):
            print(f"{name}: not rendered, skipped")
            continue
        truth = load_truth(tp)
        kw = dict(zip(("mask_left", "mask_right"), truth.exact_masks(soft=False))) if a.masks == "true" else {}
        trace.recs = {}
        res = loc.localize(cv2.imread(str(lp)), cv2.imread(str(rp)), **kw)
        tf = truth.features
        rows = [r for r in score_result(res, truth, name=name).rows if r.kind == "bifurcation"]
        n_false += sum(r.truth_index < 0 for r in rows)
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
                if a.v:
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
    if a.pickle:
        a.pickle.write_bytes(pickle.dumps(saved))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
