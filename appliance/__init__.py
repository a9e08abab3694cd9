"""appliance: the stereo vision box of an apple-harvesting robot."""

import importlib.metadata


def software_version() -> str:
    """The installed appliance version ("unknown" in a source tree without metadata)."""
    try:
        return importlib.metadata.version("appliance")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover
        return "unknown"
