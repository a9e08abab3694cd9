"""Options and helpers shared by the commands."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Optional

import typer

from appliance.config import Config, load_config
from appliance.errors import ApplianceError

ConfigOption = Annotated[
    Optional[Path],
    typer.Option("--config", "-c", help="YAML file overlaid on the default configuration."),
]


def effective_config(path: Path | None) -> Config:
    """The default configuration overlaid with ``path`` (raises ConfigError)."""
    return load_config(path)


def output_paths(*paths: Path | None) -> None:
    """Make each output file's folder and check it can be written, before the work that fills the file: a
    long job must not end on an unwritable output (raises ApplianceError naming the file). ``None`` entries
    (outputs not asked for) are skipped."""
    for path in paths:
        if path is None:
            continue
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise ApplianceError(f"{path}: cannot make its folder {path.parent} ({e.strerror or e})") from None
        if not os.access(path.parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
            raise ApplianceError(f"{path}: cannot be written")
