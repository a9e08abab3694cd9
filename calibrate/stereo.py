"""``appliance calibrate`` as one function per source: a folder of pairs, or a live device.

Each detects the board, solves the calibration (:mod:`.solve`), writes it atomically, the
optional ROS camera_info files and the report pictures next to it, and returns what was done.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2

from appliance.calibrate.board import Board
from appliance.calibrate.model import save_calibration
from appliance.calibrate.report import coverage_pair, error_chart, rectified_check
from appliance.calibrate.ros import write_camera_info
from appliance.calibrate.solve import StereoSolution, solve_stereo
from appliance.calibrate.views import Track, Views, no_track, views_from_folder


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """A finished calibration and everything written for it.

    Attributes
    ----------
    solution : StereoSolution
    views : Views
        Detection results, with the skipped pairs and why.
    out : Path
        The calibration file.
    files : list of Path
        Everything else written (report pictures, ROS files, captured pairs folder).
    """

    solution: StereoSolution
    views: Views
    out: Path
    files: list[Path] = field(default_factory=list)


def board_from(cfg, pattern: tuple[int, int] | None = None, square_mm: float | None = None) -> Board:
    """The board of the ``calibration`` config, with command-line overrides."""
    cols, rows = pattern or (cfg.pattern_cols, cfg.pattern_rows)
    return Board(cols, rows, square_mm if square_mm is not None else cfg.square_mm)


def report_paths(out: str | Path) -> dict[str, Path]:
    """Where the report pictures of calibration file ``out`` go (next to it)."""
    out = Path(out)
    return {k: out.with_name(f"{out.stem}_{k}.png") for k in ("errors", "coverage", "rectified")}


def finish(views: Views, board: Board, cfg, out: str | Path, ros_out: str | Path | None,
           source: str) -> CalibrationRun:
    """Solve, then write the calibration, the report pictures and the ROS files."""
    sol = solve_stereo(views, board, min_pairs=cfg.min_pairs, outlier_factor=cfg.outlier_factor,
                       outlier_min_px=cfg.outlier_min_px,
                       refine=cfg.refine_intrinsics, alpha=cfg.rectify_alpha, source=source)
    out = Path(out)
    save_calibration(sol.calib, out)
    paths = report_paths(out)
    cv2.imwrite(str(paths["errors"]), error_chart([v.key for v in sol.views], sol.view_rms_px))
    cv2.imwrite(str(paths["coverage"]), coverage_pair(views.image_size, [v.left_px for v in sol.views],
                                                      [v.right_px for v in sol.views]))
    cv2.imwrite(str(paths["rectified"]), rectified_check(sol.calib, *views.sample))
    files = list(paths.values())
    if ros_out is not None:
        files += write_camera_info(sol.calib, ros_out)
    return CalibrationRun(sol, views, out, files)


def calibrate_folder(folder: str | Path, cfg, out: str | Path, *, board: Board | None = None,
                     ros_out: str | Path | None = None, track: Track = no_track) -> CalibrationRun:
    """Calibrate from a folder of left/right chessboard pairs.

    Parameters
    ----------
    folder : str or Path
        Pairs found by name (:func:`appliance.acquire.pairs.find_pairs`).
    cfg : CalibrationConfig
    out : str or Path
        Calibration file to write (atomically; a failure leaves an existing file alone).
    board : Board, optional
        Defaults to the config's board.
    ros_out : str or Path, optional
        Folder for ROS ``left.yaml``/``right.yaml``.
    track : Track
        Progress display for corner detection.

    Raises
    ------
    CalibrationError
        No pairs, too few usable pairs, cameras swapped.
    """
    board = board or board_from(cfg)
    views = views_from_folder(folder, board, cfg.detector, track)
    return finish(views, board, cfg, out, ros_out, source=str(folder))
