"""Live calibration: keep the pairs that add coverage from a running stereo driver, then calibrate.

The capture stops when ``calibration.live_target_pairs`` pairs are kept and all four
coverage bars (x, y, size, skew) are full, when the user presses Enter or Ctrl-C, or when
the driver ends (a fake driver replaying a folder). Kept pairs are written as they are kept
into ``<out stem>_pairs/`` next to the calibration, so a failed calibration loses nothing.
"""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import cv2
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn

from appliance.calibrate.board import Board
from appliance.calibrate.coverage import PARAMS, adds_coverage, coverage, pose_params
from appliance.calibrate.detect import find_corners, orient_like
from appliance.calibrate.model import CalibrationError
from appliance.calibrate.stereo import CalibrationRun, board_from, finish
from appliance.calibrate.views import View, Views


def pairs_folder(out: str | Path) -> Path:
    """Where live capture saves the kept pairs of calibration file ``out``.

    ``<stem>_pairs`` next to it, or ``<stem>_pairs_2``, ``_3``, ... when that already holds files
    (earlier captures are never overwritten).
    """
    out = Path(out)
    for n in range(1, 10000):
        folder = out.with_name(f"{out.stem}_pairs" + (f"_{n}" if n > 1 else ""))
        if not folder.exists() or not any(folder.iterdir()):
            return folder
    raise CalibrationError(f"{out.parent}: too many {out.stem}_pairs_N folders")


def _watch_enter(stop: threading.Event) -> None:
    """Set ``stop`` when Enter is pressed on the terminal. Without a terminal on stdin (a script,
    a pipe, CI) stdin is not read at all: stray input (or a /dev/null that is a plain file with
    text in it, as on some sandboxes) must not end the capture before it starts."""
    try:
        if sys.stdin is None or not sys.stdin.isatty():
            return
    except (OSError, ValueError):
        return

    def wait():
        try:
            if sys.stdin.readline():
                stop.set()
        except (OSError, ValueError):
            pass
    threading.Thread(target=wait, daemon=True, name="calibrate-enter").start()


def capture_views(frames, board: Board, detector: str, target_pairs: int, folder: Path,
                  progress: Progress | None = None, stop: threading.Event | None = None) -> Views:
    """Keep the pairs of ``frames`` that see the board in both views and add coverage.

    Parameters
    ----------
    frames : iterable of StereoFrame
    board : Board
    detector : {"sb", "classic"}
    target_pairs : int
        Stop once this many are kept and coverage is full.
    folder : Path
        Kept pairs are written here as ``left_NN.png``/``right_NN.png``.
    progress : rich Progress, optional
        Shows kept pairs and the four coverage bars.
    stop : threading.Event, optional
        Set from elsewhere (Enter) to stop capturing.

    Returns
    -------
    Views
        The kept views; ``skipped`` counts frames without the whole board in both views.
    """
    folder.mkdir(parents=True, exist_ok=True)
    tasks = {}
    if progress is not None:
        tasks["pairs"] = progress.add_task("kept pairs", total=target_pairs)
        tasks.update({p: progress.add_task(f"coverage {p}", total=1.0) for p in PARAMS})
    views, kept, size, sample, seen, unseen = [], [], None, None, 0, 0
    try:
        for frame in frames:
            if stop is not None and stop.is_set():
                break
            seen += 1
            left_px = find_corners(frame.left, board, detector)
            right_px = find_corners(frame.right, board, detector) if left_px is not None else None
            if right_px is None:
                unseen += 1
                continue
            size = (frame.left.shape[1], frame.left.shape[0])
            params = pose_params(left_px, board.cols, size)
            if not adds_coverage(params, kept):
                continue
            key = f"{len(views):02d}"
            cv2.imwrite(str(folder / f"left_{key}.png"), frame.left)
            cv2.imwrite(str(folder / f"right_{key}.png"), frame.right)
            kept.append(params)
            views.append(View(key, left_px, orient_like(left_px, right_px)))
            sample = sample or (frame.left, frame.right)
            cov = coverage(kept)
            if progress is not None:
                progress.update(tasks["pairs"], completed=len(views))
                for p, c in zip(PARAMS, cov):
                    progress.update(tasks[p], completed=float(c))
            if len(views) >= target_pairs and cov.min() >= 1.0:
                break
    except KeyboardInterrupt:
        pass
    skipped = [(f"{unseen} of {seen} frames", "board not seen whole in both views")] if unseen else []
    return Views(size or (0, 0), views, skipped, sample)


def calibrate_device(device: str, cfg, out: str | Path, *, ros_out: str | Path | None = None,
                     board: Board | None = None, console: Console | None = None) -> CalibrationRun:
    """Capture chessboard pairs from ``device`` live, then calibrate them.

    Parameters
    ----------
    device : str
        Device string for :func:`appliance.acquire.open_driver`.
    cfg : Config
        Uses ``camera`` (to open the device) and ``calibration``.
    out, ros_out
        As in :func:`appliance.calibrate.stereo.calibrate_folder`.
    board : Board, optional
        Defaults to the config's board.
    console : rich Console, optional
        Where the live bars go (stderr in the command).

    Raises
    ------
    AcquireError
        The device cannot be opened or is lost.
    CalibrationError
        Too few pairs kept, cameras swapped.
    """
    from appliance.acquire import open_driver

    ccfg = cfg.calibration
    board = board or board_from(ccfg)
    folder = pairs_folder(out)
    stop = threading.Event()
    _watch_enter(stop)
    columns = (TextColumn("{task.description:<16}"), BarColumn(),
               TextColumn("{task.percentage:>3.0f}%"))
    with open_driver(device, cfg.camera) as driver, Progress(*columns, console=console) as progress:
        if console is not None:
            console.print(f"capturing from {device}: show the {board.name} board in many positions; "
                          "Enter or Ctrl-C stops", highlight=False)
        views = capture_views(driver, board, ccfg.detector, ccfg.live_target_pairs, folder, progress, stop)
    run = finish(views, board, ccfg, out, ros_out, source=device)
    return CalibrationRun(run.solution, run.views, run.out, [folder, *run.files])
