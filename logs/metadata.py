"""Metadata records of a log (MCAP metadata: name -> {str: str}).

- ``config``: ``{"yaml": ...}``, the effective configuration.
- ``calibration``: every array of the StereoCalibration as JSON (exact: floats round-trip),
  plus image size, quality figures and its own metadata.
- ``version``: appliance, python, opencv, mcap versions.
- ``device``: the device string and what the driver reported.
"""

from __future__ import annotations

import dataclasses
import json
import platform

import cv2
import numpy as np
import yaml

from appliance.calibrate.model import NODES, StereoCalibration


def config_record(config_dict: dict | None) -> dict[str, str]:
    """``config``: the configuration as YAML text (tuples become lists)."""
    plain = json.loads(json.dumps(config_dict or {}))
    return {"yaml": yaml.safe_dump(plain, sort_keys=False)}


def config_from_record(record: dict[str, str]) -> dict:
    return yaml.safe_load(record.get("yaml", "")) or {}


def calibration_record(calib: StereoCalibration) -> dict[str, str]:
    """``calibration``: arrays as JSON lists, exact."""
    out = {name: json.dumps(np.asarray(getattr(calib, name), np.float64).tolist()) for name in NODES}
    out.update(image_width=str(calib.image_size[0]), image_height=str(calib.image_size[1]),
               f_px=repr(calib.f_px), baseline_mm=repr(calib.baseline_mm),
               rms_px=repr(float(calib.rms_px)), epipolar_rms_px=repr(float(calib.epipolar_rms_px)),
               meta=json.dumps({k: str(v) for k, v in calib.meta.items()}))
    return out


def calibration_from_record(record: dict[str, str]) -> StereoCalibration:
    arrays = {name: np.asarray(json.loads(record[name]), np.float64) for name in NODES}
    for name in ("D1", "D2", "T"):
        arrays[name] = arrays[name].ravel()
    size = (int(record["image_width"]), int(record["image_height"]))
    return StereoCalibration(size, **arrays, rms_px=float(record.get("rms_px", "nan")),
                             epipolar_rms_px=float(record.get("epipolar_rms_px", "nan")),
                             meta=json.loads(record.get("meta", "{}")))


def version_record(version: str | None) -> dict[str, str]:
    """``version``: the software that wrote the log."""
    import mcap

    return {"appliance": str(version or ""), "python": platform.python_version(),
            "opencv": cv2.__version__, "mcap": getattr(mcap, "__version__", ""),
            "host": platform.node()}


def device_record(device) -> dict[str, str]:
    """``device``: a device string, or a dataclass/dict (e.g. DriverInfo) whose fields are kept."""
    if dataclasses.is_dataclass(device):
        device = dataclasses.asdict(device)
    if isinstance(device, dict):
        return {str(k): v if isinstance(v, str) else json.dumps(v) for k, v in device.items()}
    return {"device": str(device or "")}
