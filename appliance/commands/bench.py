"""`appliance bench localize`: speed of the pipeline on this machine, against OpenCV SGBM."""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path
from typing import Annotated

import typer

from appliance.commands.common import ConfigOption, effective_config

app = typer.Typer(help="Benchmarks of the pipeline on this machine.", no_args_is_help=True)


def measure(loc, left, right, mask_left=None, mask_right=None, runs: int = 30, sgbm_runs: int = 5,
            threads: int = 1) -> dict:
    """Median time per pair of ``loc.localize`` with OpenCV limited to ``threads`` threads (default one
    core; after 2 warm-up runs), per stage, and of OpenCV SGBM_3WAY on the same rectified pair:
    ``{median_ms, stages, sgbm_median_ms, runs, threads, variant, features, branches}``."""
    import cv2

    from appliance.localize.sgbm import sgbm_disparity

    before = cv2.getNumThreads()
    cv2.setNumThreads(threads)
    try:
        for _ in range(2):
            res = loc.localize(left, right, mask_left=mask_left, mask_right=mask_right)
        totals, stages = [], {}
        for _ in range(runs):
            t = time.perf_counter()
            res = loc.localize(left, right, mask_left=mask_left, mask_right=mask_right)
            totals.append((time.perf_counter() - t) * 1e3)
            for k, v in res.timings_ms.items():
                if k != "total":
                    stages.setdefault(k, []).append(v)
        gl = loc.rectifier.rectify(cv2.cvtColor(left, cv2.COLOR_BGR2GRAY), 0)
        gr = loc.rectifier.rectify(cv2.cvtColor(right, cv2.COLOR_BGR2GRAY), 1)
        sgbm = []
        for _ in range(sgbm_runs):
            t = time.perf_counter()
            sgbm_disparity(gl, gr, loc.d_range_px)
            sgbm.append((time.perf_counter() - t) * 1e3)
    finally:
        cv2.setNumThreads(before)
    return {"median_ms": round(statistics.median(totals), 3),
            "stages": {k: round(statistics.median(v), 3) for k, v in stages.items()},
            "sgbm_median_ms": round(statistics.median(sgbm), 3), "runs": runs, "threads": threads,
            "variant": loc.variant,
            "features": len(res.features), "branches": len(res.branches)}


@app.command("localize")
def localize(
    left: Annotated[Path, typer.Argument(help="Left image.")],
    right: Annotated[Path, typer.Argument(help="Right image.")],
    calib: Annotated[Path, typer.Option("--calib", help="Stereo calibration.")],
    runs: Annotated[int, typer.Option("--runs", min=1, help="Timed runs (after 2 warm-up runs).")] = 30,
    sgbm_runs: Annotated[int, typer.Option("--sgbm-runs", min=1, help="Timed SGBM runs.")] = 5,
    threads: Annotated[int, typer.Option("--threads", min=1, help="OpenCV threads (cv2.setNumThreads).")] = 1,
    paper: Annotated[bool, typer.Option("--paper", help="Time the paper's method.")] = False,
    mask_left: Annotated[Path | None, typer.Option("--mask-left", help="External left mask.")] = None,
    mask_right: Annotated[Path | None, typer.Option("--mask-right", help="External right mask.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print {median_ms, stages, sgbm_median_ms} as JSON.")] = False,
    config: ConfigOption = None,
) -> None:
    """Time the whole localization per pair on one core (or --threads; median of --runs after a
    warm-up), per stage, and OpenCV StereoSGBM (SGBM_3WAY, same disparity range) on the same
    rectified pair."""
    from appliance.commands.localize import load_inputs
    from appliance.localize import Localizer

    cfg = effective_config(config)
    cal, (img_l, img_r), (m_l, m_r) = load_inputs(calib, left, right, mask_left, mask_right)
    loc = Localizer(cal, cfg.localize, "paper" if paper else "improved")
    fig = measure(loc, img_l, img_r, m_l, m_r, runs, sgbm_runs, threads)
    median, stage_med, sgbm_med = fig["median_ms"], fig["stages"], fig["sgbm_median_ms"]
    if as_json:
        typer.echo(json.dumps(fig))
        return
    from rich.console import Console
    from rich.table import Table

    w, h = cal.image_size
    cores = "one core" if threads == 1 else f"{threads} OpenCV threads"
    table = Table(title=f"localize ({loc.variant}) at {w}x{h}, {cores}, median of {runs} runs")
    table.add_column("stage")
    table.add_column("ms", justify="right")
    for k, v in stage_med.items():
        table.add_row(k, f"{v:.2f}")
    table.add_row("[b]total[/b]", f"[b]{median:.2f}[/b]")
    table.add_row(f"OpenCV SGBM_3WAY (median of {sgbm_runs})", f"{sgbm_med:.1f}")
    table.add_row("speed-up vs SGBM", f"{sgbm_med / median:.1f}x")
    Console().print(table)
