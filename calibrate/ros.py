"""ROS ``camera_info`` YAML files (camera_calibration_parsers format) for the two cameras."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from appliance.calibrate.model import StereoCalibration


def camera_info(calib: StereoCalibration, side: str) -> dict:
    """The ``camera_info`` mapping of one camera.

    ROS's ``P`` is in pixels except its translation column: for the right camera
    ``P[0, 3] = -fx' * B`` with the baseline ``B`` in METRES, whereas our ``P2`` has it in
    millimetres; the column is divided by 1000 here.

    Parameters
    ----------
    calib : StereoCalibration
    side : {"left", "right"}
    """
    K, D, R, P = ((calib.K1, calib.D1, calib.R1, calib.P1) if side == "left"
                  else (calib.K2, calib.D2, calib.R2, calib.P2))
    P = np.array(P, np.float64)
    P[:, 3] /= 1000.0  # mm -> m

    def mat(m):
        m = np.atleast_2d(np.asarray(m, np.float64))
        return {"rows": m.shape[0], "cols": m.shape[1], "data": [float(x) for x in m.ravel()]}

    return {
        "image_width": int(calib.image_size[0]),
        "image_height": int(calib.image_size[1]),
        "camera_name": side,
        "camera_matrix": mat(K),
        "distortion_model": "plumb_bob" if D.size == 5 else "rational_polynomial",
        "distortion_coefficients": mat(np.asarray(D).reshape(1, -1)),
        "rectification_matrix": mat(R),
        "projection_matrix": mat(P),
    }


def write_camera_info(calib: StereoCalibration, folder: str | Path) -> list[Path]:
    """Write ``left.yaml`` and ``right.yaml`` into ``folder``; returns their paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for side in ("left", "right"):
        path = folder / f"{side}.yaml"
        path.write_text(yaml.safe_dump(camera_info(calib, side), sort_keys=False, default_flow_style=None))
        paths.append(path)
    return paths
