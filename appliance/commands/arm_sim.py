"""`appliance arm-sim PORT`: play the arm controller on a serial port (see appliance.arm.sim)."""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Annotated, Optional

import typer

from appliance.commands.common import ConfigOption, effective_config, stop_on_signals


def command(
    port: Annotated[str, typer.Argument(help="Serial port to listen on, e.g. /dev/ttyUSB1 or a pty.")],
    fault: Annotated[Optional[list[str]], typer.Option(
        "--fault", help="Inject a fault, repeatable: drop[=P] corrupt[=P] (probability per frame, "
                        "default 0.1), delay[=S] (answers late, default 0.2 s), disconnect[=S[/D]] "
                        "(close the port for D s every S s, default 5/1).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the fault dice.")] = 0,
    json_out: Annotated[Optional[Path], typer.Option(
        "--json-out", help="Write every event as one JSON line (flushed as it happens).")] = None,
    duration: Annotated[Optional[float], typer.Option(help="Stop after this many seconds.")] = None,
    baud: Annotated[Optional[int], typer.Option(help="Baud rate (default: serial.baud).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No line per message.")] = False,
    config: ConfigOption = None,
) -> None:
    """Decode frames, check CRCs, print obstacles, answer ACK/NACK; stop with Ctrl-C (twice: at once)."""
    from appliance.arm.sim import ArmSim, describe, parse_faults

    cfg = effective_config(config)
    faults = parse_faults(fault or [], seed)
    out = json_out.open("w", buffering=1) if json_out else None

    def on_event(event: dict) -> None:
        if out is not None:
            out.write(json.dumps(event) + "\n")
        line = None if quiet else describe(event)
        if line:
            typer.echo(line)

    stop = threading.Event()
    stop_on_signals(stop)
    sim = ArmSim(port, baud or cfg.serial.baud, faults, on_event)
    try:
        counts = sim.run(stop, duration)
    finally:
        if out is not None:
            out.close()
    typer.echo("arm-sim: " + ", ".join(f"{k} {v}" for k, v in counts.items()), err=True)
