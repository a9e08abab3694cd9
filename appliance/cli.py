"""The `appliance` command: parses, calls one function per command, prints.

Every command lives in its own module under :mod:`appliance.commands`. Errors a user
can act on (:class:`~appliance.errors.ApplianceError`, and an operating-system error on a named file: an
output folder that cannot be made, a file that cannot be written) become one line on stderr,
``error: <message>``, and exit status 1.
"""

from __future__ import annotations

import sys

import typer

from appliance.commands import arm_sim, bench, calibrate, config, devices, localize, logs, replay, run
from appliance.errors import ApplianceError

app = typer.Typer(
    name="appliance",
    help="Stereo vision box of an apple-harvesting robot: finds branches in 3D and tells the arm.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)
app.command("calibrate")(calibrate.command)
app.command("run")(run.command)
app.command("localize")(localize.command)
app.command("replay")(replay.command)
app.command("arm-sim")(arm_sim.command)
app.command("devices")(devices.command)
app.add_typer(config.app, name="config")
app.add_typer(logs.app, name="logs")
app.add_typer(bench.app, name="bench")


def main() -> None:
    """Console-script entry point."""
    try:
        app()
    except ApplianceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(1)
    except OSError as exc:
        if exc.filename is None:
            raise
        print(f"error: {exc.filename}: {exc.strerror or exc}", file=sys.stderr)
        sys.exit(1)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
