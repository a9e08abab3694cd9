"""`appliance run`: the appliance's main job (acquire -> localize -> log / arm)."""

from __future__ import annotations

import threading
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.live import Live

from appliance.commands.common import ConfigOption, effective_config, stop_on_signals

CalibOption = Annotated[Path, typer.Option("--calib", help="Calibration file (appliance calibrate --out).")]


def command(
    device: Annotated[Optional[str], typer.Option(
        "--device", "-d", help="Camera: /dev/videoN[,/dev/videoM] | gige:ADDR[,ADDR] | fake:PATH "
                               "(default: camera.device of the configuration).")] = None,
    calib: CalibOption = Path("calib.yaml"),
    log: Annotated[Optional[Path], typer.Option(
        "--log", help="Folder for MCAP field logs (default: logging.dir); see --no-log.")] = None,
    no_log: Annotated[bool, typer.Option("--no-log", help="Write no log.")] = False,
    serial: Annotated[Optional[str], typer.Option(
        "--serial", help="Arm-controller serial port (default: serial.port; none = no arm link).")] = None,
    frames: Annotated[Optional[int], typer.Option(
        "--frames", "-n", min=1, help="Stop after this many stereo pairs.")] = None,
    paper: Annotated[bool, typer.Option("--paper", help="Use the paper's variant of the method.")] = False,
    live: Annotated[bool, typer.Option(
        "--live", help="Stream the log's topics to Foxglove over a WebSocket on 127.0.0.1 "
                       "(needs pip install 'appliance[live]').")] = False,
    live_port: Annotated[int, typer.Option("--live-port", min=0, max=65535,
                                           help="TCP port of the live view.")] = 8765,
    workers: Annotated[int, typer.Option(
        "--workers", "-j", min=1, help="Localizer processes (2 on a 2-core box nearly doubles the rate).")] = 1,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No live status line.")] = False,
    config: ConfigOption = None,
) -> None:
    """Localize branches in every stereo pair from a camera; log to MCAP and send to the arm.

    Ends on Ctrl-C / SIGTERM (queues drained, log finished with its index; a second one ends it at
    once, the log then restored by `appliance logs recover`), after --frames pairs, or at the end of a
    fake: replay. A lost camera is reopened with back-off.
    """
    from appliance.calibrate.model import load_calibration
    from appliance.run import RunOptions, run_loop

    cfg = effective_config(config)
    if serial is not None:
        cfg = replace(cfg, serial=replace(cfg.serial, port=serial))
    calibration = load_calibration(calib)
    opts = RunOptions(device=device or cfg.camera.device,
                      log_dir=None if no_log else (log or Path(cfg.logging.dir)),
                      frames=frames, variant="paper" if paper else "improved",
                      live_port=live_port if live else None, workers=workers)
    stop = threading.Event()
    stop_on_signals(stop)

    console = Console(stderr=True)
    with Live(console=console, transient=False, auto_refresh=False,
              redirect_stdout=False, redirect_stderr=False) as live:
        def show(status):
            if not quiet:
                live.update(status_line(status), refresh=True)
        final = run_loop(cfg, calibration, opts, stop=stop, on_status=show)
        live.update(status_line(final), refresh=True)
    console.line()
    summary(final)


def status_line(s) -> str:
    """One line of the loop's state (rich markup)."""
    cam = "[green]camera ok[/]" if s.camera_ok else "[red]camera lost[/]"
    arm = ""
    if s.arm:
        arm = f"  arm sent {s.arm.get('sent', 0)} dropped {s.arm.get('dropped', 0)}"
    log = "" if not s.log_paths else ("  logging" if s.logging else "  [red]logging stopped[/]")
    log += f"  live {s.live['url']}" if s.live else ""
    return (f"{cam}  {s.rate_hz:5.1f} pairs/s  latency p50 {s.latency_p50_ms:5.1f} ms "
            f"p99 {s.latency_p99_ms:5.1f} ms  pairs {s.pairs} localized {s.localized}"
            f"{f'  [red]failed {s.failed_localize}[/]' if s.failed_localize else ''}  "
            f"dropped {s.dropped_localize}+{s.dropped_log} (localize+log)  "
            f"features {s.features} branches {s.branches}{arm}{log}")


def summary(s) -> None:
    """What the run did, on stdout."""
    typer.echo(f"pairs {s.pairs}, localized {s.localized}, failed {s.failed_localize}, "
               f"dropped: localizer {s.dropped_localize}, "
               f"log {s.dropped_log}, driver {s.dropped_driver}; reconnects {s.reconnects}")
    for path in s.log_paths:
        typer.echo(f"log: {path}")
