"""`appliance bench localize`."""

from __future__ import annotations

import typer

from appliance.commands.common import not_implemented

app = typer.Typer(help="Benchmarks of the pipeline on this machine.", no_args_is_help=True)


@app.command("localize")
def localize() -> None:
    """Not implemented yet."""
    not_implemented("bench localize")
