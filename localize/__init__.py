"""Branch localization from a stereo pair (pure functions over arrays; see :class:`Localizer`)."""

from appliance.localize.errors import LocalizeError
from appliance.localize.localizer import Localizer, paper_config
from appliance.localize.result import Branch, Feature, LocalizationResult, WithheldFeature

__all__ = ["Branch", "Feature", "LocalizationResult", "LocalizeError", "Localizer", "WithheldFeature", "paper_config"]
