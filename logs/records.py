"""Reading MCAP records front to back, tolerating a truncated tail.

A log whose writer was killed has no summary and ends inside a record. The mcap package's
non-seeking :class:`~mcap.stream_reader.StreamReader` reads it front to back; chunk CRCs are
checked so a half-written chunk is refused whole, and reading stops at the first record that
cannot be read. :class:`ReadStatus` then says where and why.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from mcap.exceptions import EndOfFile, InvalidMagic, McapError
from mcap.records import McapRecord
from mcap.stream_reader import CRCValidationError, StreamReader

from appliance.logs.errors import LogError


@dataclass
class ReadStatus:
    """How far a file could be read.

    Attributes
    ----------
    intact : bool
        The whole file was read, up to its footer and closing magic.
    problem : str or None
        Why reading stopped early (None when intact).
    readable_bytes : int
        Offset of the end of the last record read whole.
    size_bytes : int
        Size of the file.
    """

    intact: bool = False
    problem: str | None = None
    readable_bytes: int = 0
    size_bytes: int = 0


def iter_records(path: str | Path, status: ReadStatus | None = None, *,
                 emit_chunks: bool = False) -> Iterator[McapRecord]:
    """Every record of ``path`` in file order, chunks opened (unless ``emit_chunks``).

    Parameters
    ----------
    path : str or Path
    status : ReadStatus, optional
        Filled in as reading goes: whether the end was reached, and if not, why.
    emit_chunks : bool
        Yield Chunk records as they are instead of the records inside (faster when only
        metadata or statistics are wanted; chunk CRCs are then not checked).

    Raises
    ------
    LogError
        The file is missing or does not start like an MCAP file.
    """
    path = Path(path)
    status = status if status is not None else ReadStatus()
    if path.is_dir():
        raise LogError(f"{path}: is a folder; give one .mcap file")
    if not path.is_file():
        raise LogError(f"{path}: no such log file")
    status.size_bytes = path.stat().st_size
    with open(path, "rb") as fh:
        reader = StreamReader(fh, emit_chunks=emit_chunks, validate_crcs=not emit_chunks)
        records = reader.records
        while True:
            try:
                record = next(records)
            except StopIteration:
                status.intact, status.readable_bytes = True, status.size_bytes
                return
            except (InvalidMagic, EndOfFile, struct.error, CRCValidationError, McapError, ValueError,
                    zlib.error, MemoryError) as exc:
                if status.readable_bytes == 0:
                    raise LogError(f"{path}: not an MCAP file (or an empty one)") from None
                if status.readable_bytes == status.size_bytes:
                    status.problem = "truncated: ends without its index (the writer did not finish)"
                elif fh.tell() >= status.size_bytes:
                    status.problem = (f"truncated: the last record is incomplete and there is no index "
                                      f"(the writer did not finish); {status.readable_bytes} of "
                                      f"{status.size_bytes} bytes readable")
                else:
                    status.problem = f"unreadable record after byte {status.readable_bytes}: {exc}"
                return
            status.readable_bytes = fh.tell()
            yield record
