import dataclasses

import pytest
import yaml

from appliance.config import Config, ConfigError, config_to_dict, dump_config, load_config
from appliance.config.load import DEFAULT_PATH


def write(tmp_path, text):
    p = tmp_path / "c.yaml"
    p.write_text(text)
    return p


def test_defaults_load_into_frozen_dataclasses():
    c = load_config()
    assert isinstance(c, Config)
    assert c.localize.safety_factor_k == 1.05
    assert c.localize.working_range_mm == (500.0, 1500.0)
    assert c.serial.baud == 115200
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.serial.baud = 9600


def test_overlay_changes_only_named_keys(tmp_path):
    c = load_config(write(tmp_path, "localize:\n  prune:\n    min_length_px: 7\nserial:\n  port: /dev/ttyUSB0\n"))
    assert c.localize.prune.min_length_px == 7.0
    assert c.localize.prune.radius_factor == load_config().localize.prune.radius_factor
    assert c.serial.port == "/dev/ttyUSB0"


@pytest.mark.parametrize(
    "text, message",
    [
        ("localize:\n  prune:\n    min_length_px: -3\n", "localize.prune.min_length_px: must be >= 0, got -3"),
        ("localize:\n  prune:\n    min_lenght_px: 3\n", "localize.prune.min_lenght_px: unknown key"),
        ("serial:\n  baud: fast\n", "serial.baud: must be an integer, got 'fast'"),
        ("logging:\n  image_encoding: bmp\n", "logging.image_encoding: must be one of jpeg | png, got 'bmp'"),
        ("localize:\n  working_range_mm: [1500, 500]\n", "localize.working_range_mm: must be 0 < near < far"),
        ("camera: 3\n", "camera: must be a mapping, got 3"),
        ("arm:\n  camera_to_base: [[1, 0, 0, 0]]\n", "arm.camera_to_base: must be 4 rows of 4 numbers"),
        ("serial:\n  ack_mode: 1\n", "serial.ack_mode: must be true or false, got 1"),
        ("camera:\n  width_px: 0\n", "camera.width_px: must be > 0, got 0"),
    ],
)
def test_bad_values_name_the_key_path(tmp_path, text, message):
    with pytest.raises(ConfigError) as err:
        load_config(write(tmp_path, text))
    assert str(err.value).startswith(message)
    assert "\n" not in str(err.value)


def test_unreadable_and_invalid_yaml_name_the_file(tmp_path):
    with pytest.raises(ConfigError, match="nope.yaml: cannot read"):
        load_config(tmp_path / "nope.yaml")
    with pytest.raises(ConfigError, match=r"c.yaml: not valid YAML \(line \d+\)"):
        load_config(write(tmp_path, "a: [1,\nb: {\n"))


def test_every_schema_field_is_documented_in_default_yaml():
    text = DEFAULT_PATH.read_text()
    flat = []

    def walk(d, prefix=""):
        for k, v in d.items():
            if isinstance(v, dict):
                walk(v, f"{prefix}{k}.")
            else:
                flat.append(k)

    walk(config_to_dict(load_config()))
    lines = text.splitlines()
    for key in flat:
        i = next(i for i, ln in enumerate(lines) if ln.strip().startswith(f"{key}:"))
        documented = "#" in lines[i] or lines[i - 1].strip().startswith("#")
        assert documented, f"{key} has no comment in default.yaml"


def test_dump_round_trips(tmp_path):
    c = load_config()
    again = load_config(write(tmp_path, dump_config(c)))
    assert config_to_dict(again) == config_to_dict(c)
    assert yaml.safe_load(dump_config(c))["localize"]["safety_factor_k"] == 1.05
