"""Replay of a field log: re-run the localizer on the logged frames and compare with the logged results.

With lossless (PNG) frames and unchanged settings a replay reproduces the logged results
exactly; with JPEG frames it reproduces them up to the differences the compression makes.
"""

from __future__ import annotations

import json

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from appliance.calibrate.model import StereoCalibration
from appliance.config import Config
from appliance.localize import Localizer
from appliance.localize.result import LocalizationResult

MATCH_PX = 1.0  # a replayed feature within this distance (left image, px) of a logged one of the same kind is the same


@dataclass(frozen=True)
class FrameDiff:
    """How one replayed result differs from the logged one.

    ``added``/``removed`` count features present only in the replay / only in the log;
    ``max_abs_dz_mm`` is the largest depth change over features present in both (0 when none).
    """

    seq: int
    identical: bool
    added: int
    removed: int
    max_abs_dz_mm: float

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class ReplayReport:
    """A whole replay: one :class:`FrameDiff` per logged pair, and the new results."""

    diffs: list[FrameDiff] = field(default_factory=list)
    results: list[LocalizationResult] = field(default_factory=list)
    unlogged: int = 0   # frames that had no logged result (e.g. dropped by the writer)

    @property
    def identical(self) -> int:
        return sum(d.identical for d in self.diffs)

    def to_dict(self) -> dict:
        return {"frames": len(self.diffs), "identical": self.identical, "unlogged": self.unlogged,
                "diffs": [d.to_dict() for d in self.diffs],
                "results": [r.to_dict() for r in self.results]}


def compare_results(seq: int, logged: LocalizationResult | None, new: LocalizationResult) -> FrameDiff:
    """Features added/removed and the largest |dZ| between a logged and a replayed result."""
    if logged is None:
        return FrameDiff(seq, False, len(new.features), 0, 0.0)
    same = _comparable(logged) == _comparable(new)
    a = [(f.kind, np.array(f.left_px), f.xyz_mm[2]) for f in logged.features]
    b = [(f.kind, np.array(f.left_px), f.xyz_mm[2]) for f in new.features]
    used, dz = set(), [0.0]
    for kind, px, z in a:
        best = min((j for j in range(len(b)) if j not in used and b[j][0] == kind
                    and np.linalg.norm(b[j][1] - px) <= MATCH_PX),
                   key=lambda j: np.linalg.norm(b[j][1] - px), default=None)
        if best is not None:
            used.add(best)
            dz.append(abs(b[best][2] - z))
    matched = len(used)
    return FrameDiff(seq, same, len(b) - matched, len(a) - matched, float(max(dz)))


def _comparable(result: LocalizationResult) -> str:
    """The result without its timings, as text (so NaN equals NaN)."""
    d = result.to_dict()
    d.pop("timings_ms", None)
    return json.dumps(d, sort_keys=True)


def replay_log(path: Path, cfg: Config, calib: StereoCalibration, *, variant: str = "improved",
               log_out: Path | None = None,
               on_frame: Callable[[int], None] | None = None) -> ReplayReport:
    """Re-run the localizer on every logged pair of ``path``.

    Parameters
    ----------
    path : Path
        An appliance MCAP log.
    cfg, calib : Config, StereoCalibration
        The settings to replay with (the command defaults them to the logged ones).
    variant : str
        Localizer variant.
    log_out : Path, optional
        Folder of a new log of the replay (frames and new results).
    on_frame : callable, optional
        Called with the number of pairs replayed so far (progress).
    """
    from appliance.logs import LogWriter, iter_stereo_frames, read_results

    logged = {seq: result for seq, _stamp, result in read_results(path)}
    localizer = Localizer(calib, cfg.localize, variant=variant)
    report = ReplayReport()
    writer = None
    if log_out is not None:
        from appliance.config.load import config_to_dict
        from appliance import software_version

        writer = LogWriter(log_out, cfg.logging, calibration=calib, config_dict=config_to_dict(cfg),
                           device=f"replay:{path}", version=software_version())
    try:
        for n, frame in enumerate(iter_stereo_frames(path), 1):
            stamp_ns = (frame.stamp_left_ns + frame.stamp_right_ns) // 2
            result = localizer.localize(frame.left, frame.right, stamp_ns=stamp_ns)
            old = logged.get(frame.seq)
            report.unlogged += old is None
            report.diffs.append(compare_results(frame.seq, old, result))
            report.results.append(result)
            if writer is not None:
                writer.write_frame(frame)
                writer.write_result(result, frame.seq, np.asarray(cfg.arm.camera_to_base, float))
            if on_frame is not None:
                on_frame(n)
    finally:
        if writer is not None:
            writer.close()
    return report
