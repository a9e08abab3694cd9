"""Calibration accuracy: rendered chessboards against the true rig, and OpenCV's real sample pairs.

    python benchmarks/calibration.py [--detector sb|classic|both]

Rendered (fixtures/chessboard, truth fixtures/rig.yaml): relative error of the focal lengths and
the baseline (goal: within 0.1 %), principal point error (goal: within 1 px).
Real (OpenCV's left01..right14.jpg, 9x6 corners, 30 mm squares, published baseline ~99.8 mm;
Debian package opencv-doc): stereo RMS, epipolar RMS and the baseline found.
"""

from __future__ import annotations

import argparse
import gzip
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from appliance.calibrate import load_calibration
from appliance.calibrate.board import Board
from appliance.calibrate.stereo import calibrate_folder
from appliance.config import load_config

REPO = Path(__file__).resolve().parents[1]
OPENCV_DATA = Path("/usr/share/doc/opencv-doc/examples/data")


def rendered(detector: str, cfg) -> None:
    folder, rig_path = REPO / "fixtures" / "chessboard", REPO / "fixtures" / "rig.yaml"
    if not folder.is_dir() or not rig_path.is_file():
        print("rendered: fixtures/chessboard or fixtures/rig.yaml missing (python fixtures/make_fixtures.py)")
        return
    truth = load_calibration(rig_path)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run = calibrate_folder(folder, cfg, Path(tmp) / "calib.yaml", board=_fixture_board(cfg))
        dt = time.perf_counter() - t0
    c = run.solution.calib
    rel = lambda a, b: 100 * (a - b) / b  # noqa: E731 - percent
    print(f"\nrendered chessboards ({detector}): {len(run.solution.views)} pairs used, "
          f"{len(run.views.skipped)} skipped, {len(run.solution.dropped)} dropped, {dt:.1f} s")
    print(f"  stereo RMS {c.rms_px:.3f} px, epipolar RMS {c.epipolar_rms_px:.3f} px")
    for cam, K, Kt in (("left", c.K1, truth.K1), ("right", c.K2, truth.K2)):
        print(f"  {cam:5s} fx {K[0, 0]:9.2f} ({rel(K[0, 0], Kt[0, 0]):+.3f} %)  fy {K[1, 1]:9.2f} "
              f"({rel(K[1, 1], Kt[1, 1]):+.3f} %)  principal point error "
              f"{np.hypot(K[0, 2] - Kt[0, 2], K[1, 2] - Kt[1, 2]):.2f} px")
    print(f"  rectified f {c.f_px:9.2f} px (truth {truth.f_px:.2f}, {rel(c.f_px, truth.f_px):+.3f} %)")
    print(f"  baseline    {c.baseline_mm:9.3f} mm (truth {truth.baseline_mm:.3f}, "
          f"{rel(c.baseline_mm, truth.baseline_mm):+.3f} %)")
    try:
        from appliance.synth.evaluate import score_calibration
    except ImportError:
        return
    print(f"  score_calibration: {score_calibration(c, truth)}")


def _fixture_board(cfg) -> Board:
    return Board(cfg.pattern_cols, cfg.pattern_rows, cfg.square_mm)   # the fixtures use the defaults: 9x6, 25 mm


def real(detector: str, cfg) -> None:
    if not OPENCV_DATA.is_dir():
        print("\nreal: OpenCV's sample pairs are absent (apt-get install opencv-doc)")
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "pairs"
        folder.mkdir()
        for src in OPENCV_DATA.glob("[lr][ei]*[0-9][0-9].jpg*"):
            if src.name.startswith(("left", "right")):
                dest = folder / src.name.removesuffix(".gz")
                data = src.read_bytes()
                dest.write_bytes(gzip.decompress(data) if src.suffix == ".gz" else data)
        t0 = time.perf_counter()
        run = calibrate_folder(folder, cfg, Path(tmp) / "calib.yaml", board=Board(9, 6, 30.0))
        dt = time.perf_counter() - t0
    c = run.solution.calib
    print(f"\nOpenCV sample pairs ({detector}, 9x6, 30 mm): {len(run.solution.views)} pairs used, "
          f"skipped {[n for n, _ in run.views.skipped]}, dropped {run.solution.dropped}, {dt:.1f} s")
    print(f"  stereo RMS {c.rms_px:.3f} px, epipolar RMS {c.epipolar_rms_px:.3f} px, "
          f"rectified f {c.f_px:.1f} px")
    print(f"  baseline {c.baseline_mm:.2f} mm (published ~99.8 mm), T = {np.round(c.T, 2)} mm")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--detector", choices=["sb", "classic", "both"], default="both")
    args = parser.parse_args()
    for detector in (["sb", "classic"] if args.detector == "both" else [args.detector]):
        cfg = load_config(overrides={"calibration": {"detector": detector}}).calibration
        rendered(detector, cfg)
        real(detector, cfg)


if __name__ == "__main__":
    main()
