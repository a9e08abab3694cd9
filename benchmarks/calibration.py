"""Calibration accuracy: rendered chessboards against the true rig, and OpenCV's real sample pairs.

    python benchmarks/calibration.py [--detector sb|classic|both]

Rendered (fixtures/chessboard, truth fixtures/rig.yaml; while those are not generated, the set the
tests render, tests/calibrate/render.py): relative error of the focal lengths and
the baseline (goal: within 0.1 %), principal point error (goal: within 1 px).
Real (OpenCV's left01..right14.jpg, 9x6 corners, 30 mm squares, published baseline ~99.8 mm;
Debian package opencv-doc): stereo RMS, epipolar RMS and the baseline found.
"""

from __future__ import annotations

import argparse
import gzip
import importlib.util
import tempfile
import time
from pathlib import Path


from appliance.calibrate import load_calibration
from appliance.calibrate.board import Board
from appliance.calibrate.compare import compare
from appliance.synth.evaluate import score_calibration
from appliance.synth.rig import rig_from_calibration
from appliance.calibrate.stereo import calibrate_folder
from appliance.config import load_config

REPO = Path(__file__).resolve().parents[1]
OPENCV_DATA = Path("/usr/share/doc/opencv-doc/examples/data")


def test_render(folder: Path) -> Path:
    """Render the tests' own chessboard set (tests/calibrate/render.py) into ``folder``; returns the rig path."""
    spec = importlib.util.spec_from_file_location("render", REPO / "tests" / "calibrate" / "render.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.render_chessboards(folder)


def rendered(detector: str, cfg, folder: Path, rig_path: Path) -> None:
    truth = load_calibration(rig_path)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run = calibrate_folder(folder, cfg, Path(tmp) / "calib.yaml")   # the fixtures: 9x6, 25 mm (defaults)
        dt = time.perf_counter() - t0
    c = run.solution.calib
    e = compare(c, truth)
    print(f"\nrendered chessboards {folder} ({detector}): {len(run.solution.views)} pairs used, "
          f"{len(run.views.skipped)} skipped, {len(run.solution.dropped)} dropped, {dt:.1f} s")
    print(f"  stereo RMS {c.rms_px:.3f} px, epipolar RMS {c.epipolar_rms_px:.3f} px")
    print(f"  focal length fx {e['fx_pct']:+.3f} %, fy {e['fy_pct']:+.3f} % (worst camera; goal 0.1 %)")
    print(f"  principal point {e['pp_px']:.2f} px (worst camera; goal 1 px)")
    print(f"  baseline {c.baseline_mm:.3f} mm, truth {truth.baseline_mm:.3f} mm: "
          f"{e['baseline_pct']:+.3f} % (goal 0.1 %)")
    print(f"  rectified f {c.f_px:.2f} px, truth's {truth.f_px:.2f} px: {e['f_rect_pct']:+.3f} % "
          "(a choice of the rectification, see compare.py)")
    print("  depth of true points triangulated through it, RMS: "
          + ", ".join(f"{e[k]:.3f} % at {k.rsplit('_', 1)[1]} mm" for k in e if k.startswith("depth")))
    s = score_calibration(c, rig_from_calibration(truth))
    print(f"  baseline error {s['baseline_mm']:+.3f} mm, rotation error {s['rotation_deg']:.4f} deg")


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
    print(f"  baseline {c.baseline_mm:.2f} mm (published ~99.8 mm), T = ({c.T[0]:.2f}, {c.T[1]:.2f}, {c.T[2]:.2f}) mm")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--detector", choices=["sb", "classic", "both"], default="both")
    parser.add_argument("--rendered", type=Path, default=REPO / "fixtures" / "chessboard",
                        help="folder of rendered pairs (default fixtures/chessboard)")
    parser.add_argument("--rig", type=Path, default=REPO / "fixtures" / "rig.yaml", help="their true rig")
    parser.add_argument("--skip-real", action="store_true", help="skip OpenCV's sample pairs")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder, rig = args.rendered, args.rig
        if not folder.is_dir() or not rig.is_file():
            print(f"{folder} or {rig} missing: using the tests' rendered set (tests/calibrate/render.py)")
            folder = Path(tmp) / "chessboard"
            rig = test_render(folder)
        for detector in (["sb", "classic"] if args.detector == "both" else [args.detector]):
            cfg = load_config(overrides={"calibration": {"detector": detector}}).calibration
            rendered(detector, cfg, folder, rig)
            if not args.skip_real:
                real(detector, cfg)


if __name__ == "__main__":
    main()
