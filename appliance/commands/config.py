"""`appliance config show|check`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from appliance.commands.common import ConfigOption, effective_config
from appliance.config import dump_config

app = typer.Typer(help="Show or validate the configuration.", no_args_is_help=True)


@app.command("show")
def show(config: ConfigOption = None) -> None:
    """Print the effective configuration (defaults overlaid with --config) as YAML."""
    typer.echo(dump_config(effective_config(config)), nl=False)


@app.command("check")
def check(file: Annotated[Path, typer.Argument(help="Configuration file to validate.")]) -> None:
    """Validate FILE: exit 0 and say so, or print the first problem with its key path."""
    effective_config(file)
    typer.echo(f"{file}: ok")
