"""`appliance devices`: the V4L2 cameras present, or a check that one device delivers a pair."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from appliance.acquire.listing import DEV_ROOT, SYSFS_ROOT, list_v4l2_devices
from appliance.commands.common import ConfigOption, effective_config


def command(
    probe: Annotated[Optional[str], typer.Option(
        "--probe", metavar="DEVICE",
        help="Open DEVICE (/dev/videoN[,/dev/videoM] | gige:ADDR[,ADDR] | fake:PATH) with the camera "
             "settings of --config, grab one pair and print what it is.")] = None,
    config: ConfigOption = None,
    sysfs: Annotated[Path, typer.Option(hidden=True, help="sysfs video4linux folder (tests).")] = SYSFS_ROOT,
    dev: Annotated[Path, typer.Option(hidden=True, help="Folder of the device nodes (tests).")] = DEV_ROOT,
) -> None:
    """List the V4L2 video devices (from /sys/class/video4linux) with their formats.

    GigE Vision cameras are not listed: finding them means a broadcast on the network;
    give their address (gige:ADDRESS) and check them with --probe.
    """
    if probe is not None:
        _probe(probe, effective_config(config).camera)
        return
    devices = list_v4l2_devices(sysfs, dev)
    if not devices:
        typer.echo(f"no V4L2 video devices on this machine ({sysfs} is empty or missing)")
        return
    for d in devices:
        driver = f"{d.driver}, " if d.driver else ""
        typer.echo(f"{d.node}  {d.name or '?'}  ({driver}node index {d.index})")
        for line in d.formats or [d.problem or "no capture formats (a metadata node?)"]:
            typer.echo(f"    {line}")


def _probe(device: str, camera_cfg) -> None:
    from appliance.acquire import open_driver

    with open_driver(device, camera_cfg) as driver:
        frame = next(iter(driver), None)
        info = driver.info
    serials = f", serials {', '.join(info.serials)}" if info.serials else ""
    typer.echo(f"{device}: {info.driver}, {info.width_px}x{info.height_px} {info.pixel_format} per camera, "
               f"{info.fps_hz:g} Hz{serials}")
    if frame is None:
        typer.echo(f"{device}: opened, but delivered no pair")
        raise typer.Exit(1)
    typer.echo(f"pair {frame.seq}: left {frame.left.shape}, right {frame.right.shape}, "
               f"stamp {frame.stamp_ns} ns, skew {(frame.stamp_left_ns - frame.stamp_right_ns) / 1e6:.3f} ms")
