"""`appliance logs check|recover`."""

from __future__ import annotations

import typer

from appliance.commands.common import not_implemented

app = typer.Typer(help="Check and recover MCAP field logs.", no_args_is_help=True)


@app.command("check")
def check() -> None:
    """Not implemented yet."""
    not_implemented("logs check")


@app.command("recover")
def recover() -> None:
    """Not implemented yet."""
    not_implemented("logs recover")
