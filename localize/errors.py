"""Errors of the localizer."""

from appliance.errors import ApplianceError


class LocalizeError(ApplianceError):
    """Input the localizer cannot work on (wrong image size, empty mask, ...)."""
