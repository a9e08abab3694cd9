"""`appliance arm-sim`."""

from __future__ import annotations

from appliance.commands.common import ConfigOption, not_implemented


def command(config: ConfigOption = None) -> None:
    """Not implemented yet."""
    not_implemented("arm-sim")
