"""Branch localization from a stereo pair (pure functions over arrays; see :class:`Localizer`).

:class:`Localizer` and :func:`paper_config` are imported on first use: they bring numba and the compiled kernels
(~0.5 s), which a process that only reads results (``appliance logs``, the arm link) does not need."""

from appliance.localize.errors import LocalizeError
from appliance.localize.result import Branch, Feature, LocalizationResult, WithheldFeature

__all__ = ["Branch", "Feature", "LocalizationResult", "LocalizeError", "Localizer", "WithheldFeature", "paper_config"]


def __getattr__(name: str):
    if name in ("Localizer", "paper_config"):
        from appliance.localize import localizer
        return getattr(localizer, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
