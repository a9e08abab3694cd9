"""Configuration: ``default.yaml``, its typed schema and the validating loader."""

from appliance.config.load import ConfigError, config_to_dict, dump_config, load_config
from appliance.config.schema import Config

__all__ = ["Config", "ConfigError", "config_to_dict", "dump_config", "load_config"]
