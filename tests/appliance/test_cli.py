"""The real `appliance` executable, run as a process."""

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

APPLIANCE = str(Path(sys.executable).with_name("appliance"))


def run(*args, **kw):
    return subprocess.run([APPLIANCE, *args], capture_output=True, text=True, timeout=120, **kw)


def test_help_lists_the_commands():
    r = run("--help")
    assert r.returncode == 0
    for cmd in ("calibrate", "run", "localize", "replay", "config"):
        assert cmd in r.stdout


@pytest.mark.parametrize("cmd", ["calibrate", "run", "localize", "replay", "config"])
def test_each_command_has_help(cmd):
    r = run(cmd, "--help")
    assert r.returncode == 0, r.stderr
    assert "Usage" in r.stdout


def test_config_show_prints_effective_yaml(tmp_path):
    over = tmp_path / "o.yaml"
    over.write_text("localize:\n  safety_factor_k: 1.2\n")
    r = run("config", "show", "--config", str(over))
    assert r.returncode == 0, r.stderr
    shown = yaml.safe_load(r.stdout)
    assert shown["localize"]["safety_factor_k"] == 1.2
    assert shown["localize"]["working_range_mm"] == [500.0, 1500.0]


def test_config_check_accepts_good_and_rejects_bad_with_key_path(tmp_path):
    good = tmp_path / "good.yaml"
    good.write_text("serial:\n  baud: 57600\n")
    assert run("config", "check", str(good)).returncode == 0
    bad = tmp_path / "bad.yaml"
    bad.write_text("localize:\n  prune:\n    min_length_px: -3\n")
    r = run("config", "check", str(bad))
    assert r.returncode == 1
    assert r.stderr.strip() == "error: localize.prune.min_length_px: must be >= 0, got -3"
