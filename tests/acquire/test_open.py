"""``check_device``: a device that is not there is reported without opening anything."""

from __future__ import annotations

from pathlib import Path

import pytest

from appliance.acquire import DeviceNotFound, InvalidDevice, check_device

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"


def test_a_missing_v4l2_device_is_named_as_open_driver_names_it():
    with pytest.raises(DeviceNotFound, match=r"^/dev/video9: no such device"):
        check_device("/dev/video9")
    with pytest.raises(DeviceNotFound, match=r"^/dev/video8: no such device"):
        check_device("/dev/video8,/dev/video9")


def test_a_missing_fake_path_is_named(tmp_path):
    missing = tmp_path / "none"
    with pytest.raises(DeviceNotFound, match=f"^fake:{missing}: no such folder or file$"):
        check_device(f"fake:{missing}")


def test_garbage_is_invalid_and_present_devices_pass():
    with pytest.raises(InvalidDevice, match="not a device string"):
        check_device("video0")
    assert check_device(f"fake:{SCENES}") is None
    assert check_device("gige:127.0.0.9") is None      # found only by opening it: no network here
