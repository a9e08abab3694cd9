"""Checking a log (topics, counts, duration, gaps, intact or not) and recovering a truncated one."""

from __future__ import annotations

import os
from collections import Counter
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from mcap.records import Attachment, Channel, Header, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from appliance.logs import messages as m
from appliance.logs.errors import LogError
from appliance.logs.records import ReadStatus, iter_records

GAP_FACTOR = 3.0  # frames further apart than this x the median frame period make a gap


@dataclass
class TopicSummary:
    """One topic: its schema, message count and time span (log time, ns)."""

    topic: str
    schema: str
    count: int = 0
    first_ns: int | None = None
    last_ns: int | None = None

    @property
    def rate_hz(self) -> float:
        """Mean message rate over the topic's span, Hz (0 for fewer than two messages)."""
        if self.count < 2 or self.last_ns == self.first_ns:
            return 0.0
        return (self.count - 1) / ((self.last_ns - self.first_ns) / 1e9)


@dataclass
class Gap:
    """Missing frames between two logged pairs (by seq, or by time when seq runs on)."""

    after_seq: int
    before_seq: int
    start_ns: int
    end_ns: int

    @property
    def missing(self) -> int:
        """Pairs missing by seq (0 when only the time jumped)."""
        return max(self.before_seq - self.after_seq - 1, 0)

    @property
    def duration_s(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9


@dataclass
class LogSummary:
    """What :func:`check_log` found.

    Attributes
    ----------
    path : Path
    intact : bool
        Read to its footer: finished by its writer, with its index.
    problem : str or None
        Why it is not intact.
    size_bytes, readable_bytes : int
    topics : dict of str -> TopicSummary
    metadata : list of str
        Names of the metadata records.
    frames : int
        Stereo pairs with both images.
    gaps : list of Gap
    start_ns, end_ns : int or None
        Earliest and latest message log time.
    """

    path: Path
    intact: bool
    problem: str | None
    size_bytes: int
    readable_bytes: int
    topics: dict[str, TopicSummary] = field(default_factory=dict)
    metadata: list[str] = field(default_factory=list)
    frames: int = 0
    gaps: list[Gap] = field(default_factory=list)
    start_ns: int | None = None
    end_ns: int | None = None

    @property
    def duration_s(self) -> float:
        """From the first to the last message, s."""
        return 0.0 if self.start_ns is None else (self.end_ns - self.start_ns) / 1e9

    @property
    def counts(self) -> dict[str, int]:
        """Message count per topic."""
        return {t: s.count for t, s in self.topics.items()}

    def to_dict(self) -> dict:
        d = asdict(self)
        d["path"] = str(self.path)
        d["duration_s"] = self.duration_s
        return d


def check_log(path: str | Path) -> LogSummary:
    """Summarise a log and say whether it is intact (reads it front to back, no decoding).

    Raises
    ------
    LogError
        Missing file or not an MCAP file.
    """
    status = ReadStatus()
    schemas: dict[int, str] = {}
    channels: dict[int, TopicSummary] = {}
    metadata: list[str] = []
    images: dict[str, list[tuple[int, int]]] = {m.LEFT_IMAGE: [], m.RIGHT_IMAGE: []}  # (seq, stamp)
    for record in iter_records(path, status):
        if isinstance(record, Schema):
            schemas[record.id] = record.name
        elif isinstance(record, Channel) and record.id not in channels:  # the summary repeats them
            channels[record.id] = TopicSummary(record.topic, schemas.get(record.schema_id, ""))
        elif isinstance(record, Message) and record.channel_id in channels:
            t = channels[record.channel_id]
            t.count += 1
            t.first_ns = record.log_time if t.first_ns is None else min(t.first_ns, record.log_time)
            t.last_ns = record.log_time if t.last_ns is None else max(t.last_ns, record.log_time)
            if t.topic in images:
                images[t.topic].append((record.sequence, record.log_time))
        elif isinstance(record, Metadata):
            metadata.append(record.name)
    topics = {t.topic: t for t in channels.values()}
    spans = [(t.first_ns, t.last_ns) for t in topics.values() if t.count]
    left, right = (Counter(seq for seq, _ in images[t]) for t in (m.LEFT_IMAGE, m.RIGHT_IMAGE))
    pairs = sum(min(n, right[seq]) for seq, n in left.items())
    return LogSummary(
        Path(path), status.intact, status.problem, status.size_bytes, status.readable_bytes,
        topics, metadata, pairs, find_gaps(images[m.LEFT_IMAGE]),
        min(s[0] for s in spans) if spans else None, max(s[1] for s in spans) if spans else None,
    )


def find_gaps(frames: list[tuple[int, int]]) -> list[Gap]:
    """Gaps in a run of frames: seq not following on, or a step over GAP_FACTOR x the median period.

    Parameters
    ----------
    frames : list of (seq, stamp_ns)
        In recorded order (a seq that starts again, e.g. after a reconnect, is a gap too).
    """
    if len(frames) < 2:
        return []
    seq, stamp = np.array(frames, np.int64).T
    step, dt = np.diff(seq), np.diff(stamp)
    steady = step == 1
    period = np.median(dt[steady]) if steady.any() else np.median(dt)
    jump = ~steady | (dt > GAP_FACTOR * max(period, 1))
    return [Gap(int(seq[i]), int(seq[i + 1]), int(stamp[i]), int(stamp[i + 1])) for i in np.flatnonzero(jump)]


def recover_log(src: str | Path, dst: str | Path) -> LogSummary:
    """Write a readable, indexed copy of everything whole in ``src`` (e.g. a log cut by a crash).

    ``dst`` appears only once complete (written beside it, then renamed).

    Returns
    -------
    LogSummary
        The summary of ``dst``.

    Raises
    ------
    LogError
        ``src`` is missing or not an MCAP file, ``dst`` is ``src``, or ``dst`` cannot be written.
    """
    src, dst = Path(src), Path(dst)
    if dst.exists() and src.exists() and dst.resolve() == src.resolve():
        raise LogError(f"{dst}: the recovered copy must not replace the log it is read from")
    records = iter_records(src)
    first = next(records, None)
    if not isinstance(first, Header):
        raise LogError(f"{src}: not an MCAP file")
    dst.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{dst.stem}.", suffix=".mcap", dir=dst.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            writer = Writer(fh, compression=CompressionType.NONE)
            writer.start(profile=first.profile, library=first.library)
            schema_ids: dict[int, int] = {}
            channel_ids: dict[int, int] = {}
            for record in records:
                if isinstance(record, Schema) and record.id not in schema_ids:
                    schema_ids[record.id] = writer.register_schema(record.name, record.encoding, record.data)
                elif isinstance(record, Channel) and record.id not in channel_ids:
                    channel_ids[record.id] = writer.register_channel(
                        record.topic, record.message_encoding, schema_ids.get(record.schema_id, 0),
                        record.metadata)
                elif isinstance(record, Message) and record.channel_id in channel_ids:
                    writer.add_message(channel_ids[record.channel_id], record.log_time, record.data,
                                       record.publish_time, record.sequence)
                elif isinstance(record, Metadata):
                    writer.add_metadata(record.name, record.metadata)
                elif isinstance(record, Attachment):
                    writer.add_attachment(record.create_time, record.log_time, record.name,
                                          record.media_type, record.data)
            writer.finish()
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, dst)
    except OSError as exc:
        raise LogError(f"{dst}: cannot write the recovered log ({exc.strerror or exc})") from None
    finally:
        Path(tmp).unlink(missing_ok=True)
    return check_log(dst)
