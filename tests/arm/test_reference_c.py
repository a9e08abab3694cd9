"""The C reference decoder (arm/reference/arm_decode.c) agrees with the Python one byte for byte."""

from __future__ import annotations

import json
import random
import shutil
import subprocess

import pytest

from appliance.arm import make_test_vectors
from appliance.arm import protocol as P

SOURCE = make_test_vectors.PATH.parent / "reference" / "arm_decode.c"


@pytest.fixture(scope="module")
def decoder(tmp_path_factory):
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    exe = tmp_path_factory.mktemp("c") / "arm_decode"
    subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-o", str(exe), str(SOURCE)],
                   check=True)
    return lambda data: subprocess.run([str(exe)], input=data.hex(), capture_output=True, text=True,
                                       check=True).stdout.splitlines()


def _mm3(v):
    return ",".join(f"{x:.2f}" for x in v)


def python_lines(data: bytes) -> list[str]:
    """What the C program prints, computed with the Python decoder."""
    out = []
    for item in P.FrameDecoder().feed(data):
        if isinstance(item, P.DecodeError):
            out.append(f"error={P.nack_reason(item)} seq={item.seq}")
            continue
        try:
            m = P.parse(item)
        except P.ProtocolError as exc:
            out.append(f"error={P.nack_reason(exc)} seq={item.seq}")
            continue
        head = f"seq={item.seq} "
        if isinstance(m, P.Hello):
            out.append(head + f"HELLO protocol_version={m.protocol_version} lsb_um={m.lsb_um} "
                       f"app_version={m.app_version}")
        elif isinstance(m, P.Obstacles):
            flags = m.truncated * P.FLAG_TRUNCATED | m.out_of_range * P.FLAG_OUT_OF_RANGE
            line = (head + f"OBSTACLES stamp_ns={m.stamp_ns} frame_seq={m.frame_seq} flags={flags} "
                    f"count={len(m.segments)} total={m.total}")
            for s in m.segments:
                line += (f" [p0={_mm3(s.p0_mm)} p1={_mm3(s.p1_mm)} r={s.radius_mm:.2f} "
                         f"c={s.clearance_mm:.2f} id={s.branch_id} f={int(s.recovered)}]")
            out.append(line)
        elif isinstance(m, P.Heartbeat):
            flags = m.camera_ok * P.HB_CAMERA_OK | m.calibrated * P.HB_CALIBRATED | m.ack_mode * P.HB_ACK_MODE
            out.append(head + f"HEARTBEAT stamp_ns={m.stamp_ns} flags={flags} rate_hz={m.rate_hz:.2f} "
                       f"dropped={m.results_dropped}")
        elif isinstance(m, P.Ack):
            out.append(head + f"ACK seq={m.seq}")
        else:
            out.append(head + f"NACK seq={m.seq} reason={m.reason}")
    return out


def test_c_decoder_reads_the_test_vectors_as_documented(decoder):
    doc = json.loads(make_test_vectors.PATH.read_text())
    data = b"".join(bytes.fromhex(v["hex"]) for v in doc["frames"] + doc["invalid"])
    lines = decoder(data)
    assert len(lines) == len(doc["frames"]) + len(doc["invalid"])
    assert lines == python_lines(data)
    assert lines[2].startswith("seq=2 OBSTACLES stamp_ns=1764115200033000000 frame_seq=1234 flags=0 count=2")
    assert lines[-3:] == ["error=1 seq=65535", "error=2 seq=65535", "error=2 seq=65535"]


def test_c_and_python_decoders_agree_on_corrupted_streams(decoder):
    rng = random.Random(7)
    doc = json.loads(make_test_vectors.PATH.read_text())
    frames = [bytes.fromhex(v["hex"]) for v in doc["frames"]]
    # odd but CRC-valid frames: unknown type, wrong version, payload shorter than its type says
    for version, mtype, payload in ((1, 0x42, b"xy"), (2, P.ACK, b"\1\0"), (1, P.OBSTACLES, bytes(20))):
        body = P.HEADER.pack(version, mtype, 9, len(payload)) + payload
        frames.append(P.cobs_encode(body + P.CRC.pack(P.crc16(body))) + b"\0")
    stream = bytearray()
    for _ in range(300):
        f = bytearray(rng.choice(frames))
        for _ in range(rng.choice([0, 0, 1, 2])):
            f[rng.randrange(len(f))] = rng.randrange(256)
        stream += f
        if rng.random() < 0.05:
            stream += bytes(rng.randrange(256) for _ in range(rng.randrange(1, 40)))
    stream += b"\x07" * 5000 + b"\0" + frames[0]  # an overlong frame, then resync
    data = bytes(stream)
    c_lines, py_lines = decoder(data), python_lines(data)
    assert len(c_lines) > 250 and c_lines == py_lines
    assert {"error=3 seq=9", "error=4 seq=9", "error=5 seq=9"} <= set(c_lines)
