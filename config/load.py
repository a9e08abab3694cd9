"""Load, overlay and validate configuration files into :class:`Config`.

The defaults are ``default.yaml`` next to this module. A user file overlays them
key by key (mappings merge, everything else replaces). Every problem is a
:class:`ConfigError` whose message starts with the key path, e.g.
``localize.prune.min_length_px: must be >= 0, got -3``.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from pathlib import Path
from typing import Any, Literal

import yaml

from appliance.config.schema import Config
from appliance.errors import ApplianceError

DEFAULT_PATH = Path(__file__).with_name("default.yaml")


class ConfigError(ApplianceError):
    """A configuration file or value is invalid."""


def load_config(path: str | Path | None = None, overrides: dict | None = None) -> Config:
    """Return the effective configuration.

    Parameters
    ----------
    path : str or Path, optional
        YAML file overlaid on the defaults.
    overrides : dict, optional
        Nested mapping overlaid last (used by command-line options).

    Raises
    ------
    ConfigError
        Unreadable file, unknown key, wrong type or value out of range.
    """
    data = _read_yaml(DEFAULT_PATH)
    if path is not None:
        overlay = _read_yaml(Path(path))
        data = _merge(data, overlay, prefix="", source=str(path))
    if overrides:
        data = _merge(data, overrides, prefix="", source="overrides")
    return _build(Config, data, "")


def config_to_dict(config) -> dict:
    """Plain nested dict of a config (tuples as lists), ready for YAML/JSON."""

    def plain(value):
        if isinstance(value, tuple):
            return [plain(v) for v in value]
        return value

    def walk(obj):
        return {
            f.name: walk(getattr(obj, f.name))
            if dataclasses.is_dataclass(getattr(obj, f.name))
            else plain(getattr(obj, f.name))
            for f in dataclasses.fields(obj)
        }

    return walk(config)


def dump_config(config) -> str:
    """YAML text of a config."""
    return yaml.safe_dump(config_to_dict(config), sort_keys=False, default_flow_style=False)


def _read_yaml(path: Path) -> dict:
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark else ""
        raise ConfigError(f"{path}: not valid YAML{where}: {getattr(exc, 'problem', exc)}") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: must be a mapping of sections, got {type(data).__name__}")
    return data


def _merge(base: dict, overlay: dict, prefix: str, source: str) -> dict:
    out = dict(base)
    for key, value in overlay.items():
        path = f"{prefix}{key}"
        if key not in base:
            raise ConfigError(f"{path}: unknown key (in {source})")
        if isinstance(base[key], dict):
            if not isinstance(value, dict):
                raise ConfigError(f"{path}: must be a mapping, got {_show(value)}")
            out[key] = _merge(base[key], value, prefix=f"{path}.", source=source)
        else:
            out[key] = value
    return out


def _build(cls, data: Any, path: str):
    if not isinstance(data, dict):
        raise ConfigError(f"{path or 'config'}: must be a mapping, got {_show(data)}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for key in data:
        if key not in fields:
            raise ConfigError(f"{path}{key}: unknown key")
    values = {}
    for name, f in fields.items():
        key_path = f"{path}{name}"
        if name not in data:
            raise ConfigError(f"{key_path}: missing")
        values[name] = _convert(hints[name], data[name], key_path)
        _check_range(f.metadata, values[name], key_path)
    try:
        return cls(**values)
    except ValueError as exc:
        raise ConfigError(f"{path}{exc}") from None


def _convert(tp, value, path: str):
    if dataclasses.is_dataclass(tp):
        return _build(tp, value, f"{path}.")
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        (inner,) = [a for a in args if a is not type(None)]
        return _convert(inner, value, path)
    if origin is Literal:
        if value not in args:
            choices = " | ".join(str(a) for a in args)
            raise ConfigError(f"{path}: must be one of {choices}, got {_show(value)}")
        return value
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise ConfigError(f"{path}: must be a list, got {_show(value)}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v, f"{path}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ConfigError(f"{path}: must be a list of {len(args)} values, got {len(value)}")
        return tuple(_convert(a, v, f"{path}[{i}]") for i, (a, v) in enumerate(zip(args, value)))
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{path}: must be true or false, got {_show(value)}")
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{path}: must be an integer, got {_show(value)}")
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{path}: must be a number, got {_show(value)}")
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{path}: must be a string, got {_show(value)}")
        return value
    raise TypeError(f"{path}: unsupported type {tp!r} in schema")  # a bug in schema.py


def _check_range(meta, value, path: str) -> None:
    if value is None or not meta:
        return
    if meta.get("min") is not None and value < meta["min"]:
        raise ConfigError(f"{path}: must be >= {meta['min']}, got {_show(value)}")
    if meta.get("max") is not None and value > meta["max"]:
        raise ConfigError(f"{path}: must be <= {meta['max']}, got {_show(value)}")
    if meta.get("gt") is not None and value <= meta["gt"]:
        raise ConfigError(f"{path}: must be > {meta['gt']}, got {_show(value)}")


def _show(value) -> str:
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, dict | list):
        return type(value).__name__
    return str(value).lower() if isinstance(value, bool) else str(value)
