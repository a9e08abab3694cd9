"""`appliance arm-sim` as a real process: answers, printed lines, faults, restarts, errors."""

from __future__ import annotations

import json
import subprocess
import time

import numpy as np
import serial

from appliance.arm import make_test_vectors
from appliance.arm import protocol as P
from appliance.arm.link import ArmLink
from armtest import APPLIANCE, make_result, serial_cfg


def read_frames(port, want: int, timeout_s: float = 5.0) -> list:
    dec, out = P.FrameDecoder(), []
    deadline = time.monotonic() + timeout_s
    while len(out) < want and time.monotonic() < deadline:
        out += [P.parse(f) for f in dec.feed(port.read(4096)) if isinstance(f, P.Frame)]
        time.sleep(0.005)
    return out


def test_sim_acks_vectors_nacks_bad_crc_and_prints(bridge, tmp_path, start_sim):
    doc = json.loads(make_test_vectors.PATH.read_text())
    frames = {v["name"]: bytes.fromhex(v["hex"]) for v in doc["frames"] + doc["invalid"]}
    sim = start_sim(bridge.sim_path, tmp_path / "sim.jsonl")
    with serial.Serial(str(bridge.link_path), 115200, timeout=0) as port:
        port.write(b"\x13\x37garbage\0" + frames["hello"] + frames["obstacles_two"] + frames["bad_crc"]
                   + frames["heartbeat"])
        answers = read_frames(port, 4)
    out, err = sim.stop()
    # garbage before the first 0x00 is rejected too, then HELLO and OBSTACLES ACKed, the bad CRC NACKed
    assert answers == [P.Nack(P.SEQ_UNKNOWN, P.NACK_BAD_FRAME), P.Ack(0), P.Ack(2),
                       P.Nack(P.SEQ_UNKNOWN, P.NACK_BAD_CRC)]
    assert "OBSTACLES seq 2 frame 1234" in out and "2/2 segments" in out
    assert "branch 3 (412.5, -80.2, 1030.0)-(398.0, -20.8, 1012.5) mm r 12.50" in out
    assert "HEARTBEAT camera ok, calibrated, 29.97 Hz, 3 dropped" in out
    assert "NACK seq 65535: bad_crc" in out
    assert "obstacles 1" in err and "errors 2" in err
    (obs,) = sim.obstacles()
    assert obs == {**doc["frames"][2]["message"], "event": "message", "seq": 2, "t": obs["t"]}


def test_sim_delay_fault_makes_the_link_retransmit(bridge, tmp_path, start_sim):
    sim = start_sim(bridge.sim_path, tmp_path / "sim.jsonl", "-q", "--fault", "delay=0.15")
    link = ArmLink(serial_cfg(bridge.link_path, ack_mode=True, ack_timeout_s=0.1, max_retries=3),
                   np.eye(4)).open()
    link.submit(make_result(0), 0)
    time.sleep(0.6)
    stats = link.stats()
    link.close()
    sim.stop()
    # the ACK comes after 150 ms: one retransmission (same seq), then the late ACK is taken
    assert stats["retransmits"] == 1 and stats["acked"] == 1 and stats["gave_up"] == 0
    assert [o["frame_seq"] for o in sim.obstacles()] == [0, 0]
    assert len({o["seq"] for o in sim.obstacles()}) == 1


def test_sim_restart_loses_only_what_was_sent_while_it_was_down(bridge, tmp_path, start_sim):
    link = ArmLink(serial_cfg(bridge.link_path), np.eye(4)).open()
    first = start_sim(bridge.sim_path, tmp_path / "one.jsonl", "-q")
    for i in range(10):
        link.submit(make_result(i), i)
        time.sleep(0.01)
    first.wait_for(lambda evs: sum(e.get("type") == "OBSTACLES" for e in evs) == 10, "10 results")
    first.stop()
    for i in range(10, 20):  # nobody listening
        link.submit(make_result(i), i)
        time.sleep(0.01)
    second = start_sim(bridge.sim_path, tmp_path / "two.jsonl", "-q")
    for i in range(20, 30):
        link.submit(make_result(i), i)
        time.sleep(0.01)
    second.wait_for(lambda evs: any(e.get("frame_seq") == 29 for e in evs), "result 29")
    stats = link.stats()
    link.close()
    second.stop()
    assert [o["frame_seq"] for o in first.obstacles()] == list(range(10))
    assert [o["frame_seq"] for o in second.obstacles()] == list(range(20, 30))
    assert stats["sent"] == 30 and stats["disconnects"] == 0


def test_sim_missing_port_and_bad_fault_are_one_line_errors(tmp_path):
    missing = str(tmp_path / "ttyNONE")
    for args, words in ((["arm-sim", missing], [missing, "No such file"]),
                        (["arm-sim", missing, "--fault", "drop=2"], ["--fault drop=2", "out of range"]),
                        (["arm-sim", missing, "--fault", "melt"], ["--fault melt", "unknown fault"])):
        proc = subprocess.run([str(APPLIANCE), *args], capture_output=True, text=True, timeout=30)
        assert proc.returncode == 1
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
        assert all(w in lines[0] for w in words), lines[0]


def test_sim_disconnect_fault_loses_a_stretch_and_comes_back(bridge, tmp_path, start_sim):
    sim = start_sim(bridge.sim_path, tmp_path / "sim.jsonl", "-q", "--fault", "disconnect=0.8/0.4")
    link = ArmLink(serial_cfg(bridge.link_path), np.eye(4)).open()
    for i in range(50):
        link.submit(make_result(i), i)
        time.sleep(0.04)
    time.sleep(0.2)
    stats = link.stats()
    link.close()
    sim.stop()
    events = sim.events()
    got = [e["frame_seq"] for e in events if e.get("type") == "OBSTACLES"]
    assert sum(e["event"] == "disconnect" for e in events) >= 1
    assert got == sorted(set(got)) and got[0] < 10
    # a stretch of results went while the port was closed; results came again after it
    gaps = [(b - a - 1, a) for a, b in zip(got, got[1:])]
    missing, before = max(gaps)
    assert missing >= 5 and got[-1] > before + missing
    assert stats["sent"] == 50 and stats["disconnects"] == 0  # the sender did not notice
