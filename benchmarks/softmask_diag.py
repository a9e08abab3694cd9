"""Which end checks flip between the binary and the soft exact masks (issue 5, soft masks).

    python benchmarks/softmask_diag.py [--extra 24]

Runs the improved localizer on each scene with the binary exact masks and with the soft ones
(the renderer's coverage), records per end (graph node, by its skeleton position) where
:class:`EndPlacer` hid it (the source line of the ``hidden.add``) or where it placed it, and prints
the ends whose outcome differs, with the check's line.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter

import cv2
import numpy as np

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent))
from localize_accuracy import REPO, scenes  # noqa: E402

from appliance.config import load_config  # noqa: E402
from appliance.localize import ends as ends_mod  # noqa: E402
from appliance.calibrate.model import load_calibration  # noqa: E402
from appliance.localize import Localizer  # noqa: E402
from appliance.synth.truth import load_truth  # noqa: E402


class _Why(set):
    """A set that remembers the source line that added each member."""

    def __init__(self):
        super().__init__()
        self.why: dict[int, str] = {}

    def add(self, x):
        f = sys._getframe(1)
        self.why.setdefault(int(x), f"{f.f_code.co_name}:{f.f_lineno}")
        super().add(x)


def run(loc, left, right, masks, placers):
    placers.clear()
    loc.localize(left, right, mask_left=masks[0], mask_right=masks[1])
    out = {}
    for p in placers:
        for node in range(len(p.g.node_kind)):
            if len(p.incident[node]) != 1:
                continue
            key = tuple(np.rint(p.node_xy[node]).astype(int).tolist())
            if node in p.hidden.why:
                out[key] = ("hidden", p.hidden.why[node], None)
            elif node in p.uvd:
                out[key] = ("tip", "", p.uvd[node].copy())
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--extra", type=int, default=24)
    a = ap.parse_args()
    placers: list = []
    orig = ends_mod.EndPlacer.__init__

    def init(self, *args, **kw):
        orig(self, *args, **kw)
        self.hidden = _Why()
        placers.append(self)

    ends_mod.EndPlacer.__init__ = init
    cfg = load_config().localize
    loc = Localizer(load_calibration(REPO / "fixtures" / "rig.yaml"), cfg, "improved")
    flips = Counter()
    for name, lp, rp, tp in scenes(a.extra):
        left, right, truth = cv2.imread(str(lp)), cv2.imread(str(rp)), load_truth(tp)
        b = run(loc, left, right, truth.exact_masks(soft=False), placers)
        s = run(loc, left, right, truth.exact_masks(soft=True), placers)
        ks = np.array(list(s) or [(-99, -99)])
        pairs, seen = [], set()
        for key in b:                      # the skeletons may differ a little: nearest end within 8 px
            dist = np.abs(ks - np.array(key)).max(1)
            j = int(dist.argmin())
            sk = tuple(ks[j].tolist()) if dist[j] <= 8 else None
            pairs.append((key, sk))
            seen.add(sk)
        pairs += [(None, k) for k in s if k not in seen]
        for kb_, ks_ in pairs:
            key = kb_ or ks_
            ob, os_ = b.get(kb_, ("-", "", None)), s.get(ks_, ("-", "", None))
            if ob[:2] != os_[:2]:
                flips[(ob[1] or ob[0], os_[1] or os_[0])] += 1
                print(f"{name} end {key}: binary {ob[0]} {ob[1]} -> soft {os_[0]} {os_[1]}")
            elif ob[0] == "tip" and os_[0] == "tip":
                duv = os_[2] - ob[2]
                if np.abs(duv).max() > 0.5:
                    print(f"{name} end {key}: tip moved (du, dv, dd) = {np.round(duv, 2).tolist()}")
    print("\nflips (binary -> soft):")
    for (x, y), n in flips.most_common():
        print(f"  {n:3d}  {x} -> {y}")


if __name__ == "__main__":
    main()
