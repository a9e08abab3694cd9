"""`appliance calibrate`: chessboard stereo calibration from a folder of pairs or a live device."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.progress import track as rich_track

from appliance.commands.common import ConfigOption


def command(
    images: Annotated[Optional[Path], typer.Option(
        "--images", metavar="DIR", help="Folder of left/right chessboard pairs (left01.png/right01.png, ...).")] = None,
    device: Annotated[Optional[str], typer.Option(
        "--device", metavar="DEV", help="Capture pairs live from DEV (/dev/videoN | gige:ADDR | fake:PATH).")] = None,
    pattern: Annotated[Optional[str], typer.Option(
        help="Inner corners COLSxROWS, e.g. 9x6 [default: calibration.pattern_cols x pattern_rows].")] = None,
    square_mm: Annotated[Optional[float], typer.Option(
        "--square-mm", help="Side of one square, mm [default: calibration.square_mm].")] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Calibration file to write.")] = Path("calib.yaml"),
    ros_out: Annotated[Optional[Path], typer.Option(
        "--ros-out", metavar="DIR", help="Also write ROS camera_info left.yaml/right.yaml into DIR.")] = None,
    detector: Annotated[Optional[str], typer.Option(
        help="sb (findChessboardCornersSB) | classic (findChessboardCorners + cornerSubPix).")] = None,
    min_pairs: Annotated[Optional[int], typer.Option(
        "--min-pairs", help="Fewer usable pairs is an error [default: calibration.min_pairs].")] = None,
    config: ConfigOption = None,
) -> None:
    """Calibrate the stereo rig from chessboard pairs: writes f, b, intrinsics, rectification and a report.

    The report pictures go next to --out: NAME_errors.png (per-view reprojection errors),
    NAME_coverage.png (where corners were seen), NAME_rectified.png (rectification check).
    """
    from appliance.calibrate import stereo
    from appliance.calibrate.board import parse_pattern
    from appliance.calibrate.summary import notes, summary_table
    from appliance.config import load_config

    if (images is None) == (device is None):
        raise typer.BadParameter("give exactly one of --images DIR or --device DEV")
    overrides = {k: v for k, v in dict(detector=detector, min_pairs=min_pairs, square_mm=square_mm).items()
                 if v is not None}
    if pattern is not None:
        overrides["pattern_cols"], overrides["pattern_rows"] = parse_pattern(pattern)
    cfg = load_config(config, overrides={"calibration": overrides})
    console = Console(stderr=True)

    def track(items, total, description):
        return rich_track(items, total=total, description=description, console=console, transient=False)

    if images is not None:
        run = stereo.calibrate_folder(images, cfg.calibration, out, ros_out=ros_out, track=track)
    else:
        from appliance.calibrate.live import calibrate_device

        run = calibrate_device(device, cfg, out, ros_out=ros_out, console=console)
    for line in notes(run):
        console.print(line, highlight=False)
    Console().print(summary_table(run))
    typer.echo(f"wrote {run.out}")
    for path in run.files:
        typer.echo(f"wrote {path}")
