"""Skeleton, pruning, recovery, radius and features on real tree photographs (no stereo).

    python benchmarks/real_branches.py [--only NAME] [--runs 5] [--figures docs/figures]

Fixtures: fixtures/real (photographs from Debian packages, branch masks made by
fixtures/real/make_real.py). For each fixture and each variant the localizer's left-image
stages run on the given mask with the library's own functions, chained as
``Localizer._graph`` chains them:

- ``paper``: full-size thinning, spurs < 5 px pruned, Hough recovery.
- ``improved``: the default configuration (thinning of a 4x smaller mask, spurs shorter than
  max(5 px, 1.5 x the junction's radius) pruned, a junction's one spur leaving the view kept,
  collinear bridging; without the colour recogniser every gap counts as covered by an occluder).
- ``full``: the improved pruning and recovery on the paper's full-size skeleton (table only).

Prints per fixture and variant: mask px, skeleton px, endpoints / bifurcations before and
after pruning, spurs pruned (endpoints removed by pruning), gaps bridged, loops (closed loops
of the final skeleton: twigs that cross in the image, or holes in the mask), bumps (one-pixel
side segments that make a false bifurcation, see ``ChainResult.bumps``), radius
median px (over the final skeleton's pixels), and stage times (median of ``--runs``, ms).
Writes one figure per fixture, ``real_<name>.jpg``: the paper variant on the left, the
improved one on the right; mask outline grey, skeleton coloured by radius (turbo: blue thin
... red thick, scale in the corner), numbered '+' at endpoints (yellow) and bifurcations
(magenta), bridged gaps as white lines flagged 'B'.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
from appliance.config import load_config
from appliance.config.schema import LocalizeConfig
from appliance.localize.graph import ENDPOINT, JUNCTION, SkeletonGraph, build_graph
from appliance.localize.localizer import paper_config
from appliance.localize.prune import prune
from appliance.localize.radius import RadiusMap, radius_at, ridge_radius_map
from appliance.localize.recover import recover
from appliance.localize.segment import occluder_at
from appliance.localize.skeleton import skeletonize

REPO = Path(__file__).resolve().parents[1]
STAGES = ("skeleton", "radius", "prune", "recover", "features")


def load_real():
    """The module fixtures/real/make_real.py (fixture list, crops, committed masks)."""
    spec = importlib.util.spec_from_file_location("make_real", REPO / "fixtures" / "real" / "make_real.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("make_real", mod)      # (dataclasses look their module up there)
    spec.loader.exec_module(mod)
    return mod


@dataclass(frozen=True, eq=False)
class ChainResult:
    """One mask through skeleton -> radius -> prune -> recover -> features.

    Attributes
    ----------
    raw, graph : SkeletonGraph
        Before pruning; after pruning and recovery.
    radius : RadiusMap
    endpoints_xy, bifurcations_xy : ndarray (N, 2)
        Features of ``graph``, full-resolution (x, y) px.
    timings_ms : dict
        Per stage (``STAGES``), ms.
    """

    raw: SkeletonGraph
    graph: SkeletonGraph
    radius: RadiusMap
    endpoints_xy: np.ndarray
    bifurcations_xy: np.ndarray
    timings_ms: dict

    @property
    def bridged(self) -> int:
        return int(self.graph.seg_recovered.sum())

    @property
    def spurs_pruned(self) -> int:
        """Endpoints of the raw skeleton no longer in the pruned one (one per removed spur)."""
        img = self.graph.image()
        yx = self.raw.node_yx[self.raw.node_kind == ENDPOINT].astype(int)
        return int((img[yx[:, 0], yx[:, 1]] == 0).sum())

    @property
    def loops(self) -> int:
        """Closed loops of the seen skeleton: the background regions it encloses (4-connected
        background of the 8-connected skeleton, less the outer one)."""
        bg = cv2.copyMakeBorder(1 - self.graph.image(), 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=1)
        return cv2.connectedComponents(bg, connectivity=4)[0] - 2

    @property
    def bumps(self) -> int:
        """One-pixel segments touching one junction only: a pixel on the outside of a turn of the
        skeleton that ``remove_corners`` keeps; it has two neighbours (so it is no endpoint and
        pruning never sees it) and makes its neighbours a false junction."""
        g = self.graph
        loose = (g.seg_nodes < 0).sum(axis=1) == 1
        return int(sum(1 for k in np.flatnonzero(loose & ~g.seg_recovered) if len(g.seg_yx[k]) == 1))

    def radius_px(self) -> np.ndarray:
        """Radius at every pixel of the final (seen) skeleton, full-resolution px."""
        yx = np.argwhere(self.graph.image() > 0)
        return radius_at(self.radius, self.graph.to_full(yx))


def count_kinds(graph: SkeletonGraph) -> tuple[int, int]:
    """(endpoints, bifurcations) of a graph."""
    return int((graph.node_kind == ENDPOINT).sum()), int((graph.node_kind == JUNCTION).sum())


def run_chain(mask: np.ndarray, cfg: LocalizeConfig, img: np.ndarray | None = None) -> ChainResult:
    """The localizer's single-image stages on a branch mask (H, W) uint8 0/255, as
    ``Localizer._graph`` runs them, then the features (endpoints and bifurcations). With the
    photograph ``img`` (BGR), a long gap is bridged only over a leaf or an apple, as the localizer
    does with external masks."""
    t = [time.perf_counter()]

    def lap():
        t.append(time.perf_counter())

    skel = skeletonize(mask, cfg.skeleton.method, cfg.skeleton.downscale)
    lap()
    radius = ridge_radius_map(skel.mask, 3, skel.scale) if skel.scale > 1 else ridge_radius_map(mask)
    lap()
    raw = build_graph(skel)      # the counts before pruning (prune builds its own): not timed
    t[-1] = time.perf_counter()
    _, graph = prune(skel, cfg.prune.min_length_px, cfg.prune.radius_factor, radius,
                     keep_border=cfg.prune.keep_border_spurs)
    lap()
    occluded = None if img is None else (lambda xy: occluder_at(img, xy, cfg.segment))
    graph = recover(graph, cfg.recover, radius, occluded)
    lap()
    ends = graph.to_full(graph.node_yx[graph.node_kind == ENDPOINT])
    forks = graph.to_full(graph.node_yx[graph.node_kind == JUNCTION])
    lap()
    times = dict(zip(STAGES, np.diff(t) * 1e3))
    return ChainResult(raw, graph, radius, ends, forks, times)


def variants(cfg: LocalizeConfig) -> dict[str, LocalizeConfig]:
    """The chains compared: the paper's steps, the default (improved) configuration, and the
    improved pruning and recovery on the paper's full-size skeleton ("full")."""
    return {"paper": paper_config(cfg), "improved": cfg,
            "full": replace(cfg, skeleton=replace(cfg.skeleton, method="thinning"))}


def draw(img: np.ndarray, mask: np.ndarray, res: ChainResult, title: str, r_max: float, zoom: float = 2.0) -> np.ndarray:
    """One panel: the image ``zoom`` times larger with the chain's result (see module docstring)
    under a line naming the variant and its counts."""
    out = cv2.resize(img, None, fx=zoom, fy=zoom, interpolation=cv2.INTER_CUBIC)
    out = (0.55 * out + 0.45 * 255).astype(np.uint8)          # paler, so the drawing stands out
    big = cv2.resize(mask, (out.shape[1], out.shape[0]), interpolation=cv2.INTER_NEAREST)
    contours, _ = cv2.findContours(big, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    cv2.drawContours(out, contours, -1, (110, 110, 110), 1)
    g = res.graph
    lut = cv2.applyColorMap(np.arange(256, dtype=np.uint8)[:, None], cv2.COLORMAP_TURBO)[:, 0]
    dot = max(1, int(g.scale * zoom / 2))

    def at(xy):
        return (int(round((xy[0] + 0.5) * zoom - 0.5)), int(round((xy[1] + 0.5) * zoom - 0.5)))

    yx = np.argwhere(g.image() > 0)
    xy = g.to_full(yx)
    r = radius_at(res.radius, xy)
    cols = lut[np.clip(r / r_max * 255, 0, 255).astype(int)]
    for p, c in zip(xy, cols):
        cv2.circle(out, at(p), dot, tuple(int(v) for v in c), -1)
    for k in np.flatnonzero(g.seg_recovered):
        a, b = (g.to_full(g.node_yx[n])[0] for n in g.seg_nodes[k])
        cv2.line(out, at(a), at(b), (255, 255, 255), 3, cv2.LINE_AA)
        cv2.line(out, at(a), at(b), (0, 0, 0), 1, cv2.LINE_AA)
        m = (np.array(at(a)) + np.array(at(b))) // 2
        cv2.putText(out, "B", (int(m[0]) + 4, int(m[1]) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 2, cv2.LINE_AA)
        cv2.putText(out, "B", (int(m[0]) + 4, int(m[1]) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1,
                    cv2.LINE_AA)
    n = 0
    for pts, colour in ((res.bifurcations_xy, (255, 0, 255)), (res.endpoints_xy, (0, 200, 255))):
        for p in pts:
            c = at(p)
            cv2.drawMarker(out, c, (0, 0, 0), cv2.MARKER_CROSS, 11, 3)
            cv2.drawMarker(out, c, colour, cv2.MARKER_CROSS, 11, 1)
            cv2.putText(out, str(n), (c[0] + 4, c[1] - 3), cv2.FONT_HERSHEY_SIMPLEX, 0.33, colour, 1, cv2.LINE_AA)
            n += 1
    bar = np.repeat(lut[None, :, :], 8, 0)[:, ::2]
    h = out.shape[0]
    out[h - 12:h - 4, 6:6 + bar.shape[1]] = bar
    for txt, x in (("r 0", 6), (f"{r_max:.0f} px", 6 + bar.shape[1] - 30)):
        cv2.putText(out, txt, (x, h - 16), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    head = np.full((22, out.shape[1], 3), 255, np.uint8)
    label = (f"{title}: {len(res.endpoints_xy)} endpoints, {len(res.bifurcations_xy)} bifurcations, "
             f"{res.bridged} bridged")
    cv2.putText(head, label, (6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    out = np.vstack([head, out])
    return out


def figures_row(res: ChainResult) -> dict:
    """The printed figures of one chain."""
    ep0, bf0 = count_kinds(res.raw)
    ep1, bf1 = len(res.endpoints_xy), len(res.bifurcations_xy)
    r = res.radius_px()
    return {"skeleton_px": int(res.graph.image().sum()), "ep_raw": ep0, "bf_raw": bf0, "ep": ep1, "bf": bf1,
            "spurs": res.spurs_pruned, "bridged": res.bridged, "loops": res.loops, "bumps": res.bumps,
            "radius_med_px": float(np.median(r)) if len(r) else float("nan")}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="one fixture name")
    ap.add_argument("--runs", type=int, default=5, help="runs per chain (stage times: median)")
    ap.add_argument("--figures", type=Path, default=REPO / "docs" / "figures")
    ap.add_argument("--quality", type=int, default=70, help="JPEG quality of the figures")
    ap.add_argument("--panel-px", type=int, default=900, help="longest side of a figure panel (px)")
    ap.add_argument("--panel-area", type=int, default=300_000, help="largest area of a figure panel (px)")
    args = ap.parse_args(argv)
    real = load_real()
    cfg = load_config().localize
    head = (f"{'fixture':<13} {'variant':<9} {'size':>8} {'mask px':>8} {'skel px':>7} {'ep raw':>6} "
            f"{'bf raw':>6} {'ep':>4} {'bf':>4} {'spurs':>5} {'bridged':>7} {'loops':>5} {'bumps':>5} {'r med px':>8}  "
            + " ".join(f"{s:>8}" for s in STAGES) + "  (ms)")
    print(head)
    args.figures.mkdir(parents=True, exist_ok=True)
    for fx in real.FIXTURES:
        if args.only and fx.name != args.only:
            continue
        img, mask = real.load(fx.name)
        results = {}
        for vname, vcfg in variants(cfg).items():
            runs = [run_chain(mask, vcfg, img) for _ in range(max(1, args.runs) + 1)][1:]   # first: warm-up
            res = replace(runs[-1], timings_ms={s: float(np.median([r.timings_ms[s] for r in runs])) for s in STAGES})
            results[vname] = res
            f = figures_row(res)
            print(f"{fx.name:<13} {vname:<9} {img.shape[1]:>4}x{img.shape[0]:<3} {int(np.count_nonzero(mask)):>8} "
                  f"{f['skeleton_px']:>7} {f['ep_raw']:>6} {f['bf_raw']:>6} {f['ep']:>4} {f['bf']:>4} "
                  f"{f['spurs']:>5} {f['bridged']:>7} {f['loops']:>5} {f['bumps']:>5} {f['radius_med_px']:>8.2f}  "
                  + " ".join(f"{res.timings_ms[s]:>8.2f}" for s in STAGES), flush=True)
        r_max = max(8.0, float(np.percentile(np.concatenate([r.radius_px() for r in results.values()]), 99)))
        zoom = min(4.0, args.panel_px / max(img.shape[:2]), np.sqrt(args.panel_area / img[..., 0].size))
        panels = [draw(img, mask, results[v], v, r_max, zoom) for v in ("paper", "improved")]
        sep = np.full((panels[0].shape[0], 6, 3), 255, np.uint8)
        path = args.figures / f"real_{fx.name}.jpg"
        cv2.imwrite(str(path), np.hstack([panels[0], sep, panels[1]]), [cv2.IMWRITE_JPEG_QUALITY, args.quality])
        print(f"  -> {path.relative_to(REPO) if path.is_relative_to(REPO) else path} ({path.stat().st_size // 1024} kB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
