"""Reading a field log back: stereo frames, results, metadata.

Everything reads front to back with :func:`~appliance.logs.records.iter_records`, so a log
cut short by a crash reads as far as it is whole.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Iterator

from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from mcap.records import Channel, Message, Metadata

from appliance.acquire.frame import StereoFrame
from appliance.localize.result import LocalizationResult
from appliance.logs import messages as m
from appliance.logs.images import decode_image
from appliance.logs.metadata import calibration_from_record, config_from_record
from appliance.logs.records import ReadStatus, iter_records

PENDING_MAX = 256  # an image whose partner has not come within this many messages is dropped


def iter_messages(path: str | Path, topics=None,
                  status: ReadStatus | None = None) -> Iterator[tuple[Channel, Message]]:
    """(channel, message) of every message in file order, optionally only on ``topics``."""
    channels: dict[int, Channel] = {}
    for record in iter_records(path, status):
        if isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Message):
            channel = channels.get(record.channel_id)
            if channel is not None and (topics is None or channel.topic in topics):
                yield channel, record


def iter_stereo_frames(path: str | Path) -> Iterator[StereoFrame]:
    """The logged stereo pairs in recorded order, decoded.

    Left and right images are paired by their seq (the MCAP message sequence); an image
    without a partner (e.g. cut off by a crash) is skipped.

    Raises
    ------
    LogError
        Missing file or not an MCAP file.
    """
    pending: dict[tuple[str, int], CompressedImage] = {}
    for channel, msg in iter_messages(path, (m.LEFT_IMAGE, m.RIGHT_IMAGE)):
        image = CompressedImage.FromString(msg.data)
        other = m.RIGHT_IMAGE if channel.topic == m.LEFT_IMAGE else m.LEFT_IMAGE
        partner = pending.pop((other, msg.sequence), None)
        if partner is None:
            pending[(channel.topic, msg.sequence)] = image
            if len(pending) > PENDING_MAX:
                pending.pop(next(iter(pending)))
            continue
        left, right = (image, partner) if channel.topic == m.LEFT_IMAGE else (partner, image)
        yield StereoFrame(decode_image(left.data), decode_image(right.data), msg.sequence,
                          m.stamp_ns_of(left.timestamp), m.stamp_ns_of(right.timestamp))


def read_results(path: str | Path) -> list[tuple[int, int, LocalizationResult]]:
    """Every logged result as (seq, stamp_ns, LocalizationResult), in recorded order."""
    out = []
    for _, msg in iter_messages(path, (m.RESULT,)):
        d = m.result_from_json(msg.data)
        out.append((int(d.get("seq", msg.sequence)), int(d.get("stamp_ns") or msg.log_time),
                    LocalizationResult.from_dict(d)))
    return out


def read_diagnostics(path: str | Path) -> list[dict]:
    """Every ``/diagnostics`` mapping, in recorded order."""
    return [json.loads(msg.data) for _, msg in iter_messages(path, (m.DIAGNOSTICS,))]


def read_log_metadata(path: str | Path) -> dict:
    """The metadata records of a log.

    Returns
    -------
    dict
        ``config`` (dict, {} if absent), ``calibration`` (StereoCalibration or None),
        ``version`` (dict), ``device`` (str: the device string), ``device_info`` (dict: the
        whole record), ``records`` (every metadata record by name, raw).
    """
    records: dict[str, dict] = {}
    for record in iter_records(path, emit_chunks=True):
        if isinstance(record, Metadata):
            records.setdefault(record.name, dict(record.metadata))
            if {"config", "calibration", "version", "device"} <= records.keys():
                break
    calib = records.get("calibration")
    device = records.get("device", {})
    return {
        "config": config_from_record(records.get("config", {})),
        "calibration": calibration_from_record(calib) if calib else None,
        "version": records.get("version", {}),
        "device": device.get("device", ""),
        "device_info": device,
        "records": records,
    }
