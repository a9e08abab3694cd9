"""Topics of a field log and the Foxglove messages written on them.

Foxglove's well-known schemas come from ``foxglove-schemas-protobuf`` (precompiled protobuf
classes); a log therefore opens in Foxglove with images, 3D and plots without setup.
Foxglove works in metres: millimetres of the appliance are divided by 1000 here.

Frames: ``camera`` is the left camera's optical frame (X right, Y down, Z forward),
``camera_right`` the right camera's, ``arm_base`` the arm's base.
"""

from __future__ import annotations

import json

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.CylinderPrimitive_pb2 import CylinderPrimitive
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.timestamp_pb2 import Timestamp

from appliance.calibrate.model import StereoCalibration
from appliance.calibrate.ros import camera_info

LEFT_IMAGE = "/camera/left/image"
RIGHT_IMAGE = "/camera/right/image"
LEFT_CALIBRATION = "/camera/left/calibration"
RIGHT_CALIBRATION = "/camera/right/calibration"
RESULT = "/localize/result"
BRANCHES = "/localize/branches"
TF = "/tf"
TF_STATIC = "/tf_static"
DIAGNOSTICS = "/diagnostics"

CAMERA_FRAME = "camera"
RIGHT_FRAME = "camera_right"
ARM_FRAME = "arm_base"

# Protobuf topics -> message class; JSON topics -> (schema name, JSON schema).
PROTOBUF_TOPICS = {
    LEFT_IMAGE: CompressedImage, RIGHT_IMAGE: CompressedImage,
    LEFT_CALIBRATION: CameraCalibration, RIGHT_CALIBRATION: CameraCalibration,
    BRANCHES: SceneUpdate, TF: FrameTransform, TF_STATIC: FrameTransform,
}
_XYZ = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}
_UV = {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2}
RESULT_SCHEMA = {
    "title": "appliance.LocalizationResult",
    "description": "Features and branches found in one stereo pair (mm, left camera optical frame).",
    "type": "object",
    "properties": {
        "seq": {"type": "integer"},
        "stamp_ns": {"type": "integer"},
        "features": {"type": "array", "items": {"type": "object", "properties": {
            "id": {"type": "integer"}, "kind": {"type": "string", "enum": ["endpoint", "bifurcation"]},
            "left_px": _UV, "right_px": _UV, "xyz_mm": _XYZ,
            "radius_mm": {"type": "number"}, "safe_depth_mm": {"type": "number"}}}},
        "branches": {"type": "array", "items": {"type": "object", "properties": {
            "id": {"type": "integer"},
            "feature_ids": {"type": "array", "items": {"type": "integer"}},
            "polyline_mm": {"type": "array", "items": _XYZ},
            "radius_mm": {"type": "number"}, "recovered": {"type": "boolean"}}}},
        "withheld": {"type": "array", "items": {"type": "object", "properties": {
            "kind": {"type": "string", "enum": ["endpoint", "bifurcation"]}, "left_px": _UV,
            "disparity_px": {"type": "number"}, "check_disparity_px": {"type": "number"},
            "reason": {"type": "string"}}}},
        "timings_ms": {"type": "object", "additionalProperties": {"type": "number"}},
    },
}
DIAGNOSTICS_SCHEMA = {
    "title": "appliance.Diagnostics",
    "description": "Run-loop health: rates (Hz), latencies (ms), drop counters, temperatures if known.",
    "type": "object",
}
JSON_TOPICS = {RESULT: RESULT_SCHEMA, DIAGNOSTICS: DIAGNOSTICS_SCHEMA}

SEEN_COLOR = (0.55, 0.35, 0.17, 0.9)       # bark brown: branches seen in both images
RECOVERED_COLOR = (1.0, 0.6, 0.0, 0.9)     # orange: bridged across an occlusion


def timestamp(stamp_ns: int) -> Timestamp:
    """A protobuf Timestamp from ns since the epoch."""
    return Timestamp(seconds=int(stamp_ns) // 1_000_000_000, nanos=int(stamp_ns) % 1_000_000_000)


def stamp_ns_of(ts: Timestamp) -> int:
    """ns since the epoch of a protobuf Timestamp."""
    return ts.seconds * 1_000_000_000 + ts.nanos


def image_message(data: bytes, fmt: str, stamp_ns: int, frame_id: str) -> CompressedImage:
    """A CompressedImage holding already-encoded ``data`` (``fmt``: "jpeg" | "png")."""
    return CompressedImage(timestamp=timestamp(stamp_ns), frame_id=frame_id, data=data, format=fmt)


def calibration_messages(calib: StereoCalibration, stamp_ns: int) -> tuple[CameraCalibration, CameraCalibration]:
    """The left and right cameras' CameraCalibration (ROS conventions: P's baseline in metres)."""
    out = []
    for side, frame_id in (("left", CAMERA_FRAME), ("right", RIGHT_FRAME)):
        info = camera_info(calib, side)
        out.append(CameraCalibration(
            timestamp=timestamp(stamp_ns), frame_id=frame_id,
            width=info["image_width"], height=info["image_height"],
            distortion_model=info["distortion_model"],
            D=info["distortion_coefficients"]["data"], K=info["camera_matrix"]["data"],
            R=info["rectification_matrix"]["data"], P=info["projection_matrix"]["data"],
        ))
    return out[0], out[1]


def quaternion_from_matrix(rot: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a 3x3 rotation matrix (Shepperd's method, w >= 0)."""
    m = np.asarray(rot, np.float64)
    tr = np.trace(m)
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i], q[j], q[k] = s / 4, (m[j, i] + m[i, j]) / s, (m[k, i] + m[i, k]) / s
    q = np.array(q) / np.linalg.norm(q)
    q = -q if q[3] < 0 else q
    return tuple(float(v) for v in q)


def transform_message(parent_to_child_pose: np.ndarray, stamp_ns: int, parent: str, child: str) -> FrameTransform:
    """A FrameTransform placing ``child`` in ``parent``.

    Parameters
    ----------
    parent_to_child_pose : ndarray, shape (4, 4)
        Maps points of the child frame into the parent frame, translation in mm
        (``p_parent = M @ p_child``).
    """
    m = np.asarray(parent_to_child_pose, np.float64).reshape(4, 4)
    x, y, z, w = quaternion_from_matrix(m[:3, :3])
    t = m[:3, 3] / 1000.0
    return FrameTransform(timestamp=timestamp(stamp_ns), parent_frame_id=parent, child_frame_id=child,
                          translation=Vector3(x=t[0], y=t[1], z=t[2]),
                          rotation=Quaternion(x=x, y=y, z=z, w=w))


def camera_to_base_message(camera_to_base: np.ndarray, stamp_ns: int) -> FrameTransform:
    """``/tf``: the camera frame in the arm base frame (``p_base = camera_to_base @ p_camera``, mm)."""
    return transform_message(camera_to_base, stamp_ns, ARM_FRAME, CAMERA_FRAME)


def right_camera_message(calib: StereoCalibration, stamp_ns: int) -> FrameTransform:
    """``/tf_static``: the right camera in the left one (``X_right = R X_left + T``, inverted)."""
    pose = np.eye(4)
    pose[:3, :3] = calib.R.T
    pose[:3, 3] = -calib.R.T @ np.asarray(calib.T, np.float64).reshape(3)
    return transform_message(pose, stamp_ns, CAMERA_FRAME, RIGHT_FRAME)


def cylinder_poses(polyline_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres (N-1, 3) m, orientations (N-1, 4) xyzw and lengths (N-1,) m of a polyline's segments.

    A Foxglove cylinder's axis is its local Z; the quaternion turns Z onto each segment.
    """
    p = np.asarray(polyline_mm, np.float64).reshape(-1, 3) / 1000.0
    d = np.diff(p, axis=0)
    length = np.linalg.norm(d, axis=1)
    u = d / np.maximum(length, 1e-12)[:, None]
    # Rotation Z -> u: q = (z x u, 1 + z.u), normalised; u = -Z turns about X.
    q = np.stack([-u[:, 1], u[:, 0], np.zeros(len(u)), 1.0 + u[:, 2]], axis=1)
    flip = q[:, 3] < 1e-9
    q[flip] = (1.0, 0.0, 0.0, 0.0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return (p[1:] + p[:-1]) / 2, q, length


def branches_message(result, stamp_ns: int) -> SceneUpdate:
    """``/localize/branches``: one entity ``branches`` with one cylinder per polyline segment.

    Each update replaces the previous one (same entity id); no branches -> an empty entity.
    """
    cylinders = []
    for branch in result.branches:
        centres, quats, lengths = cylinder_poses(branch.polyline_mm)
        d = 2.0 * float(branch.radius_mm) / 1000.0
        r, g, b, a = RECOVERED_COLOR if branch.recovered else SEEN_COLOR
        for c, q, length in zip(centres, quats, lengths):
            cylinders.append(CylinderPrimitive(
                pose=Pose(position=Vector3(x=c[0], y=c[1], z=c[2]),
                          orientation=Quaternion(x=q[0], y=q[1], z=q[2], w=q[3])),
                size=Vector3(x=d, y=d, z=float(length)), bottom_scale=1.0, top_scale=1.0,
                color=Color(r=r, g=g, b=b, a=a)))
    entity = SceneEntity(timestamp=timestamp(stamp_ns), frame_id=CAMERA_FRAME, id="branches",
                         cylinders=cylinders)
    return SceneUpdate(entities=[entity])


def result_json(result, seq: int) -> bytes:
    """``/localize/result``: the result contract (``LocalizationResult.to_dict``) plus ``seq``.

    NaN and infinities become ``null`` (JSON has none; Foxglove would refuse the message);
    :func:`result_from_json` turns them back into NaN.
    """
    return to_json({**result.to_dict(), "seq": int(seq)})


def result_from_json(data: bytes) -> dict:
    """The mapping written by :func:`result_json`, ``null`` numbers back as NaN."""
    return _nulls_to_nan(json.loads(data))


def to_json(value) -> bytes:
    """Strict JSON of plain data and numpy values; non-finite floats as ``null``."""
    return json.dumps(_finite(value), separators=(",", ":"), allow_nan=False).encode()


def _finite(value):
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, np.ndarray):
        return _finite(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)


def _nulls_to_nan(value):
    if isinstance(value, dict):
        return {k: _nulls_to_nan(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_nulls_to_nan(v) for v in value]
    return float("nan") if value is None else value
