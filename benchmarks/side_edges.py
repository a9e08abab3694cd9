"""The steep fork sides' rows on the mask's outline against the grey image's sub-pixel outline (issue 5).

    python benchmarks/side_edges.py [--extra 56 | --seeds A-B] [--masks true|colour|both] [--band 750-1250]
                                    [--pickle OUT] [--axis] [--set MODULE.NAME=VALUE ...]

``side_rows.py``'s trace (``band_tail.py``'s: the improved localizer on cached scenes), and for every steep side
read from its crossings (``forkdisp.side_disparity_near``) its rows (:func:`side_rows.side_rows`, the kernel's
steps in numpy, with the crotch's second read as the kernel takes it) on three sets of run boundaries of the same
pair:

- ``mask``: the soft mask's coverage crossings (``edges.find_runs``), nothing moved;
- ``used``: the runs the side read sees (``dense.match_dense``: all moved by the mask's bias, those within
  ``END_REACH_PX`` of a graph end moved to the grey outline);
- ``grey``: every run refined (``subpixel.refine_runs`` without ``only``): the grey image's outline on every
  steep boundary.

Per side and boundary set: the rows the robust line keeps, their residuals about that line (the rows' noise, px),
the lag-1 correlation of the residuals of consecutive kept rows (along the rows: pooled
``sum r_i r_i+1 / sum r_i^2``) and the line's value at the fork against the fork's true disparity plus the
silhouette bias (``centreaxis.centre_bias_px``: the side's error, px). Prints the tables by mask source and by
side (all, crotch / other side, reaching the fork or not), then how much of the sides' error the rows' scatter
explains (a line's white-noise error at the fork) and how alike the mask's and the grey reads' errors are; with
``--axis`` the rows against the true parent axis (:func:`axis_report`). Nothing of the localizer is changed: the
reads themselves use ``used`` as the localizer does.
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import band_tail  # noqa: E402
import side_rows as sr  # noqa: E402

from appliance.localize import centreaxis, dense, forkdisp  # noqa: E402

VERSIONS = ("mask", "used", "grey")


def read_rows(c, runs_l, runs_r, t_fork, **kw):
    """``side_rows`` as the kernel chooses between the plain read and the crotch's second one."""
    rows = sr.side_rows(c, runs_l, runs_r, t_fork, grow=False, **kw)
    if rows["line"].any() and np.abs(rows["x"][rows["line"]]).min() > forkdisp.SIDE_GROWN_SHORT_PX:
        grown = sr.side_rows(c, runs_l, runs_r, t_fork, **kw)
        if grown["line"].sum() >= max(12, rows["line"].sum() + forkdisp.SIDE_GROWN_MIN_ROWS):
            rows = grown
    return rows


def line_stats(rows) -> dict | None:
    """The robust line's value at the fork (x = 0), its kept rows' residuals and their lag-1 products."""
    k = rows["line"]
    if k.sum() < 12:
        return None
    x, d = rows["x"][k], rows["d"][k]
    a, b = np.polyfit(x, d, 1)
    res = d - (a * x + b)
    order = np.argsort(x)
    xs, rs = x[order], res[order]
    adj = np.abs(np.diff(xs)) == 1
    return dict(d0=float(b), slope=float(a), res=res, x=x, d=d, lag=(rs[:-1] * rs[1:])[adj], n=int(k.sum()),
                nearest=float(np.abs(x).min()))


def main() -> int:
    ap = sr.tracer_parser(__doc__.splitlines()[0])
    ap.add_argument("--axis", action="store_true", help="also the rows against the true parent axis (axis_report)")
    a = ap.parse_args()

    alt = {}                    # id(runs the placer sees) -> (those runs, {version: runs})
    orig_refine = dense.refine_runs

    def refine(runs, gray, mask, only=None, **kw):
        out = orig_refine(runs, gray, mask, only, **kw)
        if len(alt) >= 2:           # (a new pair: left then right)
            alt.clear()
        alt[id(out)] = (out, dict(mask=runs, used=out, grey=orig_refine(runs, gray, mask, None, **kw)))
        return out
    dense.refine_runs = refine

    def on_read(v, c, runs_l, runs_r, t_fork, kw):
        if id(runs_l) not in alt or id(runs_r) not in alt:
            return None
        vl, vr = alt[id(runs_l)][1], alt[id(runs_r)][1]
        return {m: line_stats(read_rows(c, vl[m], vr[m], t_fork, **kw)) for m in VERSIONS}, kw, float(v.d_px)

    def on_fork(b, loc, f, kept):
        xy = np.asarray(loc["xy"], float)
        cdir = sr.child_direction(b, loc)
        f["xy"] = xy.copy()
        for s, keep in kept:
            if keep is None:
                continue
            st, kw, d_px = keep
            c = b.curves[s["seg"]]
            # crotch side: the side's rows lie on the child's side of the fork's row
            lo, hi = c.t_range
            side_sign = 1.0 if _t(c, xy) < lo else -1.0           # rows run from the fork this way
            crotch = None if cdir is None else bool(np.sign(cdir[1]) == side_sign)
            bias = centreaxis.centre_bias_px(d_px, float(xy[0]), s["radius_px"], kw["f_px"], kw["cx_px"],
                                             kw.get("offset_px", 0.0))
            s["edges"] = dict(st=st, bias=bias, crotch=crotch, d_kernel=d_px)
    sr.trace_sides(on_read, on_fork)

    argv = sr.band_tail_argv(a)
    rows_by = {}        # (scene, masks, truth index) -> the evaluator's row (its left_err_px: the placement's error)
    orig_score = band_tail.score_result
    masks = ["true", "colour"] if a.masks == "both" else [a.masks]
    calls = {}

    def score(res, truth, name=None, **kw):
        out = orig_score(res, truth, name=name, **kw)
        k = calls[name] = calls.get(name, -1) + 1           # (band_tail scores each scene's masks in this order)
        for r in out.rows:
            rows_by[(name, masks[k], r.truth_index)] = r
        return out
    band_tail.score_result = score
    recs = sr.band_tail_records(argv)
    for r in recs:
        row = rows_by.get((r["scene"], r["masks"], r["t"]))
        r["left_err_px"] = None if row is None else float(row.left_err_px)
    if a.pickle:
        a.pickle.write_bytes(pickle.dumps(recs))
    report(recs)
    if a.axis:
        axis_report(recs, {name: tp for name, _, _, tp in band_tail.scene_list(a.extra, a.seeds)})
    return 0


def true_axis_rdv(truth, branch: int, step_mm: float = 0.5):
    """The true branch's axis (sampled every ``step_mm``) in the left rectified view: columns, rows and
    disparities (px), through the truth's own rig; and ``(rect, f, off, fb)`` to project other points."""
    c = truth.rig.calibration()
    r1, p1, p2 = np.asarray(c.R1), np.asarray(c.P1), np.asarray(c.P2)
    ax = np.asarray(truth.branches[branch].axis_mm, float)
    seg = np.linalg.norm(np.diff(ax, axis=0), axis=1)
    n = np.maximum(np.ceil(seg / step_mm).astype(int), 1)
    pts = np.concatenate([ax[i] + np.linspace(0, 1, n[i], endpoint=False)[:, None] * (ax[i + 1] - ax[i])
                          for i in range(len(seg))] + [ax[-1:]])

    def rect(xyz):
        x = np.asarray(xyz, float) @ r1.T
        return (p1[0, 0] * x[..., 0] / x[..., 2] + p1[0, 2], p1[1, 1] * x[..., 1] / x[..., 2] + p1[1, 2],
                -p2[0, 3] / x[..., 2] + p1[0, 2] - p2[0, 2])
    return (*rect(pts), rect)


def axis_report(recs, truth_paths: dict) -> None:
    """Each read side's rows (``used``) against the TRUE parent axis on the same rows (minus the silhouette bias):
    the line through those differences at the fork (the line against the axis), the rows' mean difference, a
    straight line through the true axis on the same rows at the fork against the true axis there (the straight
    line's model error: the parent bends in depth), the true axis at the placed fork's row against the fork's true
    disparity (the placement along the parent), and,
    for sides reaching the fork, the rows' mean difference per stretch of one radius (how far a stretch of rows
    is off the axis together)."""
    out = []
    for r, f, sides, truth in sr.forks_with_truth(recs, truth_paths,
                                                  lambda s: s.get("edges") and s["edges"]["st"]["used"] is not None):
        u, v, d, rect = true_axis_rdv(truth, int(truth.features.parent[r["t"]]))
        xf = np.asarray(f["xy"], float)
        d_true = r["d"] - r["derr"]
        near = np.hypot(u - xf[0], v - xf[1]) < 400
        for s in sides:
            e, st = s["edges"], s["edges"]["st"]["used"]
            rows = xf[1] + st["x"]
            dt = np.full(len(rows), np.nan)
            for k, rv in enumerate(rows):          # (a few dozen rows a side)
                cand = np.flatnonzero(near & (np.abs(v - rv) < 0.6))
                if len(cand):
                    dt[k] = d[cand[np.argmin(np.abs(v[cand] - rv))]]
            ok = np.isfinite(dt)
            cand = np.flatnonzero(near & (np.abs(v - xf[1]) < 0.6))
            if ok.sum() < 8 or not len(cand):
                continue
            rowerr = st["d"][ok] - e["bias"] - dt[ok]
            sel = near & (v >= rows.min()) & (v <= rows.max())
            slant = abs(np.polyfit(v[sel], u[sel], 1)[0]) if sel.sum() >= 3 else np.nan     # |du/dv| of the true axis
            d_row = d[cand[np.argmin(np.abs(v[cand] - xf[1]))]]         # the true axis on the placed fork's row
            out.append(dict(m=r["masks"], err=st["d0"] - e["bias"] - d_true, line=np.polyfit(st["x"][ok], rowerr, 1)[1],
                            model=np.polyfit(st["x"][ok], dt[ok], 1)[1] - d_row,
                            rows=rowerr.mean(), place=d_row - d_true,
                            reach=st["nearest"] < 2, x=st["x"][ok], rowerr=rowerr, rad=s["radius_px"], slant=slant))
    print("\n| masks | sides | reach | side error sd px | line against the true axis, at the fork: sd | rows' mean against "
          "it: sd | a straight line through the true axis, at the fork: sd | true axis at the placed row against the "
          "fork's truth: sd | per one-radius stretch of rows: sd (stretches) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for m in ("true", "colour"):
        for grp, sel in (("all", lambda x: True), ("< 2 px", lambda x: x["reach"]), ("short", lambda x: not x["reach"])):
            o = [x for x in out if x["m"] == m and sel(x)]
            if len(o) < 2:
                continue
            sd = {k: np.std([x[k] for x in o]) for k in ("err", "line", "rows", "model", "place")}
            per = [x["rowerr"][k].mean() for x in o
                   for lo in range(8) for k in [(np.abs(x["x"]) >= lo * x["rad"]) & (np.abs(x["x"]) < (lo + 1) * x["rad"])]
                   if k.sum() >= 3]
            print(f"| {m} | {len(o)} | {grp} | {sd['err']:.3f} | {sd['line']:.3f} | {sd['rows']:.3f} | {sd['model']:.3f} | "
                  f"{sd['place']:.3f} | {np.std(per) if per else np.nan:.3f} ({len(per)}) |")
    # the renderer's 2 x 2 supersampling places a near-vertical outline with an error that keeps its phase over many
    # rows (docs/localize-rendering.md): the line against the true axis by the outline's slant from the vertical
    print("\n| masks | reach | slant from vertical | sides | line against the true axis at the fork: sd, p95 abs px | "
          "per one-radius stretch: sd |")
    print("|---|---|---|---|---|---|")
    for m in ("true", "colour"):
        for lo, hi in ((0, 3), (3, 10), (10, 90)):
            o = [x for x in out if x["m"] == m and x["reach"] and lo <= np.degrees(np.arctan(x["slant"])) < hi]
            if len(o) < 2:
                continue
            a = np.array([x["line"] for x in o])
            per = [x["rowerr"][k].mean() for x in o
                   for j in range(8) for k in [(np.abs(x["x"]) >= j * x["rad"]) & (np.abs(x["x"]) < (j + 1) * x["rad"])]
                   if k.sum() >= 3]
            print(f"| {m} | < 2 px | {lo}-{hi} deg | {len(o)} | {a.std():.3f}, {np.percentile(np.abs(a), 95):.3f} | "
                  f"{np.std(per):.3f} |")


def _t(c, xy):
    return float(xy[1] if c.by_row else xy[0])


def report(recs) -> None:
    """Prints the tables (see the module docstring)."""
    sides = [dict(masks=r["masks"], crotch=e["crotch"], st=e["st"],
                  err={m: e["st"][m]["d0"] - e["bias"] - d_true for m in VERSIONS})
             for r, e, d_true in sr.traced_sides(recs, "edges") if all(e["st"][m] is not None for m in VERSIONS)]
    print("| masks | sides | group | boundaries | rows kept (median) | nearest kept row px (median) | "
          "row residual p50 / p95 px | lag-1 corr | side error p50 / p95 abs px | mean abs px |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for m in ("true", "colour"):
        for grp, sel in (("all", lambda s: True), ("crotch side", lambda s: s["crotch"] is True),
                         ("other side", lambda s: s["crotch"] is False),
                         ("reaching the fork (used < 2 px)", lambda s: s["st"]["used"]["nearest"] < 2),
                         ("read > 6 px short (used)", lambda s: s["st"]["used"]["nearest"] > 6)):
            ss = [s for s in sides if s["masks"] == m and sel(s)]
            if not ss:
                continue
            for v in VERSIONS:
                res = np.abs(np.concatenate([s["st"][v]["res"] for s in ss]))
                lag = np.concatenate([s["st"][v]["lag"] for s in ss])
                sq = np.concatenate([s["st"][v]["res"] ** 2 for s in ss])
                err = np.abs([s["err"][v] for s in ss])
                print(f"| {m} | {len(ss)} | {grp} | {v} | {np.median([s['st'][v]['n'] for s in ss]):.0f} | "
                      f"{np.median([s['st'][v]['nearest'] for s in ss]):.1f} | "
                      f"{np.median(res):.3f} / {np.percentile(res, 95):.3f} | {lag.sum() / sq.sum():.2f} | "
                      f"{np.median(err):.3f} / {np.percentile(err, 95):.3f} | {err.mean():.3f} |")
    print("\n| masks | sides | side error sd (used) px | the line's white-noise error at the fork (median 2 sd / sqrt n) px | "
          "corr(mask, grey side errors) | sd(grey - mask) px | grey better / worse by > 0.05 px |")
    print("|---|---|---|---|---|---|---|")
    for m in ("true", "colour"):
        ss = [s for s in sides if s["masks"] == m]
        if len(ss) < 2:
            continue
        e = np.array([[s["err"][v] for v in VERSIONS] for s in ss])
        se = np.median([s["st"]["used"]["res"].std() * 2 / np.sqrt(s["st"]["used"]["n"]) for s in ss])
        better = int((np.abs(e[:, 2]) < np.abs(e[:, 0]) - 0.05).sum())
        worse = int((np.abs(e[:, 2]) > np.abs(e[:, 0]) + 0.05).sum())
        print(f"| {m} | {len(ss)} | {e[:, 1].std():.3f} | {se:.3f} | {np.corrcoef(e[:, 0], e[:, 2])[0, 1]:.2f} | "
              f"{(e[:, 2] - e[:, 0]).std():.3f} | {better} / {worse} |")


if __name__ == "__main__":
    raise SystemExit(main())
