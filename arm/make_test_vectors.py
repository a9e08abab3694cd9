"""Write ``arm/test_vectors.json``: frames in hex with their decoded meaning, for firmware authors.

Run ``python -m appliance.arm.make_test_vectors`` (or this file) after a protocol change; the
tests check the committed file equals what this produces and decodes as it says.
"""

from __future__ import annotations

import json
from pathlib import Path

from appliance.arm import protocol as P

PATH = Path(__file__).with_name("test_vectors.json")


def _frame(name: str, message: P.Message, seq: int, note: str = "") -> dict:
    wire = P.encode(message, seq)
    body = P.cobs_decode(wire[:-1])
    return {
        "name": name,
        "note": note,
        "hex": wire.hex(),
        "body_hex": body.hex(),
        "header": {"version": P.PROTOCOL_VERSION, "type": P.MESSAGE_TYPES[type(message)],
                   "type_name": P.TYPE_NAMES[P.MESSAGE_TYPES[type(message)]], "seq": seq,
                   "length": len(body) - P.HEADER.size - P.CRC.size},
        "crc": f"0x{P.CRC.unpack_from(body, len(body) - 2)[0]:04X}",
        "message": P.message_to_dict(message),
    }


def vectors() -> dict:
    """The whole test-vector document."""
    seg_a = P.Segment((412.5, -80.25, 1030.0), (398.0, -20.75, 1012.5), 12.5, 13.25, 3, False)
    seg_b = P.Segment((-150.0, 220.0, 1250.25), (-90.5, 260.0, 1301.0), 6.0, 6.5, 7, True)
    many = tuple(P.Segment((10.0 * i + 1, 20.25, 700.0 + i), (10.0 * i + 9, 21.5, 705.0 + i), 4.0, 4.25, i)
                 for i in range(16))
    frames = [
        _frame("hello", P.Hello("0.1.0"), 0, "first frame after every (re)connection"),
        _frame("heartbeat", P.Heartbeat(1_764_115_200_000_000_000, True, True, 29.97, False, 3), 1,
               "camera ok, calibrated, 29.97 Hz, 3 results dropped so far"),
        _frame("obstacles_two", P.Obstacles(1_764_115_200_033_000_000, 1234, (seg_a, seg_b), 2), 2,
               "two segments, nearest first; the second was bridged across an occlusion"),
        _frame("obstacles_empty", P.Obstacles(1_764_115_200_066_000_000, 1235), 3, "no branch in view"),
        _frame("obstacles_truncated", P.Obstacles(1_764_115_200_100_000_000, 1236, many, 40, True), 4,
               "16 of 40 segments: the most that fit one frame period at 115200 Bd, 30 Hz"),
        _frame("ack", P.Ack(2), 17, "controller: frame seq 2 arrived"),
        _frame("nack", P.Nack(P.SEQ_UNKNOWN, P.NACK_BAD_CRC), 18,
               "controller: a frame failed its CRC (its seq unreadable)"),
    ]
    good = bytes.fromhex(frames[2]["hex"])
    bad_crc = bytearray(P.cobs_decode(good[:-1]))
    bad_crc[-1] ^= 0x01
    invalid = [
        {"name": "bad_crc", "hex": (P.cobs_encode(bytes(bad_crc)) + b"\0").hex(), "error": "bad_crc",
         "note": "obstacles_two with one CRC bit flipped"},
        {"name": "bad_cobs", "hex": "0501020300", "error": "bad_frame",
         "note": "COBS code 0x05 announces more bytes than precede the delimiter"},
        {"name": "too_short", "hex": "03010200", "error": "bad_frame", "note": "fewer than 8 bytes decoded"},
    ]
    cobs = [{"decoded": d.hex(), "encoded": P.cobs_encode(d).hex()}
            for d in (b"", b"\0", b"\0\0", b"\x11\x22\0\x33", bytes(range(1, 255)), bytes(range(1, 256)),
                      bytes(range(1, 255)) + b"\0")]
    return {
        "protocol_version": P.PROTOCOL_VERSION,
        "description": "See arm/PROTOCOL.md. 'hex' is the whole frame as sent (COBS-encoded, 0x00 last); "
                       "'body_hex' is it decoded: header + payload + CRC. Lengths in mm.",
        "crc": {"name": "CRC-16/CCITT-FALSE", "poly": "0x1021", "init": "0xFFFF", "refin": False,
                "refout": False, "xorout": "0x0000", "input_ascii": "123456789",
                "check": f"0x{P.crc16(b'123456789'):04X}"},
        "cobs": cobs,
        "frames": frames,
        "invalid": invalid,
    }


def main() -> None:
    PATH.write_text(json.dumps(vectors(), indent=1) + "\n")
    print(f"wrote {PATH}")


if __name__ == "__main__":
    main()
