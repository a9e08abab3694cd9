"""The terminal summary of a calibration run (a rich table and notes)."""

from __future__ import annotations

import numpy as np
from rich.table import Table

from appliance.calibrate.stereo import CalibrationRun


def notes(run: CalibrationRun) -> list[str]:
    """One line per pair not used (skipped or dropped as an outlier), and unpaired images."""
    lines = [f"skipped {name}: {why}" for name, why in run.views.skipped]
    lines += [f"dropped {key}: RMS {err:.3f} px is an outlier" for key, err in run.solution.dropped]
    if run.views.unpaired:
        lines.append(f"ignored {run.views.unpaired} images without a left/right partner")
    return lines


def summary_table(run: CalibrationRun) -> Table:
    """Quality figures and the main parameters, one row each."""
    c, sol = run.solution.calib, run.solution
    view_rms = np.sqrt(np.mean(sol.view_rms_px ** 2, axis=1))
    worst = int(np.argmax(view_rms))
    t = Table(title=f"stereo calibration: {run.out}", title_justify="left")
    t.add_column("figure")
    t.add_column("value", justify="right")
    rows = [
        ("pairs used / with the board in both views", f"{len(sol.views)} / {len(run.views.views)}"),
        ("image size", f"{c.image_size[0]} x {c.image_size[1]} px"),
        ("stereo RMS reprojection error", f"{c.rms_px:.3f} px"),
        ("worst view", f"{sol.views[worst].key}: {view_rms[worst]:.3f} px"),
        ("epipolar RMS after rectification", f"{c.epipolar_rms_px:.3f} px"),
        ("rectified focal length f", f"{c.f_px:.2f} px"),
        ("baseline b", f"{c.baseline_mm:.2f} mm"),
        ("left  fx, fy / cx, cy", f"{c.K1[0, 0]:.2f}, {c.K1[1, 1]:.2f} / {c.K1[0, 2]:.2f}, {c.K1[1, 2]:.2f} px"),
        ("right fx, fy / cx, cy", f"{c.K2[0, 0]:.2f}, {c.K2[1, 1]:.2f} / {c.K2[0, 2]:.2f}, {c.K2[1, 2]:.2f} px"),
        ("T (right from left)", f"{c.T[0]:.2f}, {c.T[1]:.2f}, {c.T[2]:.2f} mm"),
    ]
    for name, value in rows:
        t.add_row(name, value)
    return t
