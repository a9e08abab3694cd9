"""Forks whose child lies along its parent (issue 5): what ``forkalong.along_fork`` makes of each junction.

    python benchmarks/fork_along.py [--extra N | --seeds A-B] [--masks true|colour] [--set MODULE.NAME=VALUE ...]
                                    [--dump F]

Scenes as ``fork_misses.py`` (cached only). Each pair runs the improved localizer with ``forkalong.along_fork``
wrapped (nothing copied): every call (a fork junction with no child outline next to the parent) is printed with
the true fork nearest its place or its junction (rectified left view, px), the place's distance from it, the
child's angle (the skeleton's lines), the outer outline's angle, where the place, the widening's onset, the outer
line's crossing with the parent's outline and the parting lie (px along the parent from the junction), the child's
angle past the parting and its radius, or why it gave up; the place the child's outline gave (``outline's
place``, px from the same true fork: only with ``--set forkends.ALONG_OVER_OUTLINE=True``, which also calls it over
that place); whether the fork was reported (``withheld`` / ``REPORTED``) and found (the evaluator's 5 px match),
and its disparity against the truth's. The right view's calls (``ForkPlacing._along_agrees``) follow the place
they confirm. A summary counts the left view's calls by how far their place lies from a true fork. ``--dump F``
pickles every call's arguments (a look at one junction); ``--set`` as ``fork_misses.py``.
"""
from __future__ import annotations

import argparse
import pickle
import sys
from collections import Counter
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fork_misses import improved_localizer, scene_list  # noqa: E402
from localize_accuracy import _seed_range, rectified_points  # noqa: E402

from appliance.localize import forkalong, forkends  # noqa: E402
from appliance.synth.evaluate import score_result  # noqa: E402
from appliance.synth.truth import load_truth  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extra", type=int, default=56)
    ap.add_argument("--seeds", metavar="A-B", type=_seed_range)
    ap.add_argument("--masks", choices=["true", "colour"], default="true")
    ap.add_argument("--dump", type=Path, help="pickle every call's arguments (the mask cropped) and diag here")
    ap.add_argument("--set", action="append", default=[], metavar="MODULE.NAME=VALUE")
    a = ap.parse_args()
    loc = improved_localizer(a.set)
    calib = loc.calib
    calls: list = []
    right = [None]              # (the right view's mask: calls there confirm a left place)
    inner = forkalong.along_fork

    def traced(mask, p, e_par, out, r_par, r_child, diag=None):
        d = {} if diag is None else diag
        hit = inner(mask, p, e_par, out, r_par, r_child, d)
        d["outline_xy"] = last[0]
        d["right_view"] = mask is right[0]
        calls.append((np.array(p, float), np.array(out, float), np.array(e_par, float), r_par, r_child, hit, d))
        if a.dump is not None:
            dumps.append((np.array(mask), np.array(p, float), np.array(e_par, float), np.array(out, float), r_par,
                          r_child))
        return hit

    forkends.along_fork = traced
    outline_fn, last = forkends.ForkPlacing._fork_from_child_outline, [None]

    def outline(placer, c1, e1, c2, e2, p0, r_par, r_child, mask=None):
        xy = outline_fn(placer, c1, e1, c2, e2, p0, r_par, r_child, mask)
        if mask is None:
            last[0] = xy
        return xy

    forkends.ForkPlacing._fork_from_child_outline = outline
    fork_fn = forkends.ForkPlacing.fork

    def fork(placer, node, final=False, needed=True):
        last[0] = None
        right[0] = placer.sm.right_mask
        n0 = len(calls)
        out = fork_fn(placer, node, final, needed)
        for c in calls[n0:]:
            c[-1]["hidden"] = int(node) in placer.hidden
            c[-1]["uvd"] = np.array(placer.uvd[node]) if node in placer.uvd else None
        return out

    forkends.ForkPlacing.fork = fork
    tally, dumps, keys = Counter(), [], []
    for name, lp, rp, tp in scene_list(a.extra, a.seeds):
        if not (tp.exists() and lp.exists() and rp.exists() and tp.with_suffix(".npz").exists()):
            continue
        truth = load_truth(tp)
        kw = dict(zip(("mask_left", "mask_right"), truth.exact_masks(soft=False))) if a.masks == "true" else {}
        calls.clear()
        res = loc.localize(cv2.imread(str(lp)), cv2.imread(str(rp)), **kw)
        tf = truth.features
        forks = [j for j in range(len(tf.kind)) if tf.kind[j] == "bifurcation" and tf.visible_left[j]]
        if not forks:
            continue
        uv = rectified_points(calib, tf.left_px[forks], 0)
        d_true = uv[:, 0] - rectified_points(calib, tf.right_px[forks], 1)[:, 0]
        rows = score_result(res, truth, name=name).rows
        found = {r.truth_index for r in rows if r.kind == "bifurcation" and r.result_id >= 0}
        for p, out, e_par, r_par, r_child, hit, d in calls:
            if d.get("right_view"):
                keys.append((name, -1))
                print(f"{name}: (the right view's construction confirming the place above: "
                      f"{'placed' if hit is not None else 'none: ' + d.get('why', '?')})")
                continue
            ref = hit[0] if hit is not None else p
            k = int(np.argmin(np.hypot(*(uv - ref).T)))
            j, off = forks[k], float(np.hypot(*(uv[k] - ref)))
            jd = float(np.hypot(*(uv[k] - p)))
            ang = np.degrees(np.arcsin(min(1.0, abs(e_par[0] * out[1] - e_par[1] * out[0]))))
            if hit is None:
                what = f"none: {d.get('why', '?')}"
                tally["none"] += 1
            else:
                band = "within 5" if off <= 5 else "5-15" if off <= 15 else ">15"
                tally[f"placed {band}"] += 1
                ol = d.get("outline_xy")
                ol = "none" if ol is None else f"{float(np.hypot(*(uv[k] - ol))):.1f}"
                what = (f"placed {off:.1f} px off (outline's place {ol}; outer {np.degrees(np.arctan(d['k_out'])):.1f} deg, s_f {d['s_f']:.0f}, "
                        f"onset {d['s'][d['i_on']]:.0f}, crossing {d['s_x']:.0f}, parting {d['s'][d['i_part']]:.0f}, child "
                        f"{np.degrees(np.arctan(d['k_mid'])):.0f} deg past it, r_c {d['r_c']:.1f}, rms {d['rms']:.2f}), "
                        f"{'found' if j in found else 'not found'}, "
                        f"{'no parent curve through it' if d.get('uvd') is None else 'withheld' if d.get('hidden', True) else 'REPORTED'}"
                        + ("" if d.get("uvd") is None else f", d {d['uvd'][2]:.2f} (truth {d_true[k]:.2f})"))
            keys.append((name, j))
            print(f"{name} T{j}: junction {jd:.0f} px from it, child {ang:.0f} deg, radii {r_par:.1f} / {r_child:.1f}: {what}")
    if a.dump is not None:
        a.dump.write_bytes(pickle.dumps(list(zip(keys, dumps))))
    print("\n" + ", ".join(f"{k} {v}" for k, v in sorted(tally.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
