"""`appliance replay`: re-run the localizer on a field log and report what changed."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from appliance.commands.common import ConfigOption, output_paths


def command(
    log: Annotated[Path, typer.Argument(help="An appliance MCAP log.", exists=False)],
    calib: Annotated[Optional[Path], typer.Option(
        "--calib", help="Calibration to replay with (default: the one in the log).")] = None,
    config: ConfigOption = None,
    json_out: Annotated[Optional[Path], typer.Option(
        "--json", help="Write the per-frame differences and the new results here.")] = None,
    log_out: Annotated[Optional[Path], typer.Option(
        "--log", help="Folder for a new MCAP log of the replay.")] = None,
    variant: Annotated[Optional[str], typer.Option(
        "--variant", help="improved | paper (default: the variant the log was made with).")] = None,
) -> None:
    """Re-run the localizer on LOG's frames with the logged (or given) calibration and configuration.

    Prints, per frame, the features added and removed against the logged result and the
    largest depth change; with lossless frames and unchanged settings every frame is identical.
    """
    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.errors import ApplianceError
    from appliance.logs import read_log_metadata
    from appliance.replay import replay_log

    if not log.is_file():
        raise ApplianceError(f"{log}: no such log file")
    meta = read_log_metadata(log)
    cfg = load_config(config) if config is not None else load_config(None, meta["config"])
    calibration = load_calibration(calib) if calib is not None else meta["calibration"]
    if calibration is None:
        raise ApplianceError(f"{log}: holds no calibration; give one with --calib")
    variant = variant or meta["device_info"].get("variant", "improved")
    if variant not in ("improved", "paper"):
        raise ApplianceError(f"--variant: must be improved or paper, got {variant!r}")
    output_paths(json_out)
    console = Console(stderr=True)
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task(f"replaying {log.name}", total=None)
        report = replay_log(log, cfg, calibration, variant=variant,
                            log_out=log_out, on_frame=lambda n: progress.update(task, completed=n))
    table = Table("seq", "identical", "added", "removed", "max |dZ| mm", title=f"replay of {log.name}")
    for d in report.diffs:
        if not d.identical:
            table.add_row(str(d.seq), "no", str(d.added), str(d.removed), f"{d.max_abs_dz_mm:.2f}")
    if table.row_count:
        Console().print(table)
    typer.echo(f"{len(report.diffs)} frames replayed, {report.identical} identical to the log, "
               f"{len(report.diffs) - report.identical} differ"
               + (f", {report.unlogged} had no logged result" if report.unlogged else ""))
    if json_out is not None:
        json_out.write_text(json.dumps(report.to_dict(), indent=1))
