"""Options and helpers shared by the commands."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from appliance.config import Config, load_config

ConfigOption = Annotated[
    Optional[Path],
    typer.Option("--config", "-c", help="YAML file overlaid on the default configuration."),
]


def effective_config(path: Path | None) -> Config:
    """The default configuration overlaid with ``path`` (raises ConfigError)."""
    return load_config(path)
