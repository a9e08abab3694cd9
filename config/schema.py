"""Typed configuration: frozen dataclasses mirroring ``default.yaml``.

Defaults live in ``default.yaml`` only; these classes carry the types and the
allowed ranges (``field(metadata=...)``: ``min``, ``max``, ``gt``). The loader
(:mod:`appliance.config.load`) builds them and is the only code that reads YAML.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal


def rng(min=None, max=None, gt=None):
    """Field with an allowed range (inclusive ``min``/``max``, exclusive ``gt``)."""
    return field(metadata={"min": min, "max": max, "gt": gt})


@dataclass(frozen=True)
class CameraConfig:
    device: str
    width_px: int = rng(gt=0)
    height_px: int = rng(gt=0)
    fps_hz: float = rng(gt=0)
    pixel_format: Literal["MJPG", "YUYV", "MONO8", "BAYER_RG8", "RGB8"] = field()
    side_by_side_left_half: Literal["left", "right"] = field()
    max_stereo_skew_ms: float = rng(min=0)
    open_timeout_s: float = rng(gt=0)
    reconnect_min_s: float = rng(gt=0)
    reconnect_max_s: float = rng(gt=0)
    out_of_sync_frames: int = rng(min=1)
    fake_rate_hz: float = field()
    fake_loop: bool = field()
    fake_restamp: bool = field()


@dataclass(frozen=True)
class CalibrationConfig:
    pattern_cols: int = rng(min=2)
    pattern_rows: int = rng(min=2)
    square_mm: float = rng(gt=0)
    min_pairs: int = rng(min=3)
    outlier_factor: float = rng(gt=1)
    outlier_min_px: float = rng(min=0)
    detector: Literal["sb", "classic"] = field()
    rectify_alpha: float = rng(min=0, max=1)
    refine_intrinsics: bool = field()
    live_target_pairs: int = rng(min=3)


@dataclass(frozen=True)
class SegmentConfig:
    method: Literal["color", "external"]
    hue_min: int = rng(min=0, max=180)
    hue_max: int = rng(min=0, max=180)
    saturation_max: int = rng(min=0, max=255)
    value_min: int = rng(min=0, max=255)
    value_max: int = rng(min=0, max=255)
    olive_hue_max: int = rng(min=0, max=90)
    olive_saturation_max: int = rng(min=0, max=255)
    grey_chroma_max: int = rng(min=0, max=255)
    pale_value_max: int = rng(min=0, max=255)
    open_px: int = rng(min=0)
    close_px: int = rng(min=0)
    min_area_px: int = rng(min=0)
    keep_radius_px: float = rng(min=0)
    keep_chroma_deg: float = rng(min=0, max=90)
    edge_window_px: int = rng(min=0)
    edge_band_px: int = rng(min=1)


@dataclass(frozen=True)
class SkeletonConfig:
    method: Literal["fast", "thinning"]
    downscale: int = rng(min=1, max=8)


@dataclass(frozen=True)
class PruneConfig:
    min_length_px: float = rng(min=0)
    radius_factor: float = rng(min=0)
    keep_border_spurs: bool = field()


@dataclass(frozen=True)
class RecoverConfig:
    method: Literal["none", "hough", "collinear"]
    max_gap_px: float = rng(min=0)
    max_angle_deg: float = rng(min=0, max=90)
    max_radius_ratio: float = rng(min=1)
    hough_threshold: int = rng(min=1)
    hough_min_length_px: float = rng(min=0)


@dataclass(frozen=True)
class MatchConfig:
    method: Literal["features", "dense"]
    row_tolerance_px: float = rng(min=0)
    max_horizontal_deg: float = rng(min=0, max=90)
    require_same_degree: bool = field()
    min_segment_px: float = rng(min=0)
    oblique_end_ratio: float = rng(min=0)
    max_disparity_gradient: float = rng(min=0)


@dataclass(frozen=True)
class FeatureCheckConfig:
    enabled: bool
    max_diff_px: float = rng(gt=0)


@dataclass(frozen=True)
class LocalizeConfig:
    working_range_mm: tuple[float, float]
    safety_factor_k: float = rng(min=1)
    segment: SegmentConfig = field()
    skeleton: SkeletonConfig = field()
    prune: PruneConfig = field()
    recover: RecoverConfig = field()
    match: MatchConfig = field()
    feature_check: FeatureCheckConfig = field()

    def __post_init__(self):
        near, far = self.working_range_mm
        if not 0 < near < far:
            raise ValueError(f"working_range_mm: must be 0 < near < far, got [{near}, {far}]")


@dataclass(frozen=True)
class LoggingConfig:
    dir: str
    image_encoding: Literal["jpeg", "png"]
    jpeg_quality: int = rng(min=1, max=100)
    chunk_size_bytes: int = rng(min=1024)
    flush_interval_s: float = rng(gt=0)
    rotate_size_bytes: int = rng(min=0)
    rotate_duration_s: float = rng(min=0)
    min_free_bytes: int = rng(min=0)
    queue_frames: int = rng(min=1)


@dataclass(frozen=True)
class SerialConfig:
    port: str | None
    baud: int = rng(gt=0)
    write_timeout_s: float = rng(gt=0)
    ack_mode: bool = field()
    ack_timeout_s: float = rng(gt=0)
    max_retries: int = rng(min=0)
    heartbeat_s: float = rng(gt=0)
    wait_for_port: bool = field()
    reconnect_min_s: float = rng(gt=0)
    reconnect_max_s: float = rng(gt=0)
    queue_results: int = rng(min=1)
    frame_rate_hz: float = rng(gt=0)
    segment_tolerance_mm: float = rng(min=0)


@dataclass(frozen=True)
class ArmConfig:
    camera_to_base: tuple[tuple[float, float, float, float], ...]

    def __post_init__(self):
        m = self.camera_to_base
        if len(m) != 4 or m[3] != (0.0, 0.0, 0.0, 1.0):
            raise ValueError("camera_to_base: must be 4 rows of 4 numbers, the last row [0, 0, 0, 1]")


@dataclass(frozen=True)
class Config:
    camera: CameraConfig
    calibration: CalibrationConfig
    localize: LocalizeConfig
    logging: LoggingConfig
    serial: SerialConfig
    arm: ArmConfig
