"""The error of this package."""

from appliance.errors import ApplianceError


class LogError(ApplianceError):
    """A log cannot be created, read or recovered (the message names the file)."""
