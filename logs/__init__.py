"""MCAP field logs: writing, reading, checking and recovering (see docs/logs.md).

    with LogWriter("logs", cfg.logging, calibration=calib, config_dict=config_to_dict(cfg),
                   device=drv.info, version=software_version()) as log:
        log.write_frame(frame)
        log.write_result(result, frame.seq, camera_to_base)
"""

from appliance.logs.check import Gap, LogSummary, TopicSummary, check_log, recover_log
from appliance.logs.errors import LogError
from appliance.logs.images import EncodedFrame, decode_image, encode_frame, encode_image
from appliance.logs.read import (
    iter_messages, iter_stereo_frames, read_diagnostics, read_log_metadata, read_results,
)
from appliance.logs.writer import LogWriter

__all__ = [
    "EncodedFrame", "Gap", "LogError", "LogSummary", "LogWriter", "TopicSummary",
    "check_log", "decode_image", "encode_frame", "encode_image", "iter_messages", "iter_stereo_frames",
    "read_diagnostics", "read_log_metadata", "read_results", "recover_log",
]
