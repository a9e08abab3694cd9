"""ArmLink over real pseudo-terminals against the simulator running as a real process."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from appliance.arm import protocol as P
from appliance.arm.link import ArmLink, ArmLinkError
from armtest import make_result, serial_cfg


def submit_paced(link, seqs, period_s, on_each=None):
    """Submit make_result(i) for i in seqs every period_s; returns (submit times, longest submit call s)."""
    times, longest = {}, 0.0
    for i in seqs:
        t0 = time.monotonic()
        link.submit(make_result(i), i)
        longest = max(longest, time.monotonic() - t0)
        times[i] = t0
        if on_each:
            on_each(i)
        time.sleep(period_s)
    return times, longest


def wait_until(predicate, timeout_s=5.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return False


def test_missing_port_is_a_one_line_error_naming_it(tmp_path):
    port = tmp_path / "ttyUSB9"
    with pytest.raises(ArmLinkError) as err:
        ArmLink(serial_cfg(port), np.eye(4)).open()
    text = str(err.value)
    assert str(port) in text and "\n" not in text and "No such file" in text


@pytest.mark.parametrize("ack_mode", [False, True])
def test_every_result_arrives_in_order_transformed(bridge, tmp_path, ack_mode, start_sim):
    sim = start_sim(bridge.sim_path, tmp_path / "sim.jsonl", "-q")
    T = np.eye(4)
    T[:3, 3] = (100.0, -20.0, 5.0)
    link = ArmLink(serial_cfg(bridge.link_path, ack_mode=ack_mode), T).open()
    link.set_status(camera_ok=True, calibrated=True, rate_hz=29.5)
    n = 40
    _, longest = submit_paced(link, range(n), 1 / 30)     # a camera's pace: the link keeps up even when loaded
    assert sim_wait(sim, lambda obs: len(obs) >= n)
    stats = link.stats()
    link.close()
    sim.stop()
    obs = sim.obstacles()
    assert [o["frame_seq"] for o in obs] == list(range(n))
    assert stats["dropped"] == 0 and stats["sent"] == n and longest < 0.1
    if ack_mode:
        assert stats["acked"] == n
    first = obs[0]
    assert first["stamp_ns"] == 1_000_000_000 and first["total"] == 3 and not first["truncated"]
    # nearest first: the 700 mm branch's two segments, then the 1200 mm one; all moved by T
    assert [s["branch_id"] for s in first["segments"]] == [11, 11, 10]
    assert np.allclose(first["segments"][0]["p0_mm"], (140.0, -20.0, 705.0))
    assert np.allclose(first["segments"][2]["p1_mm"], (100.0, 30.0, 1205.0))
    assert first["segments"][0]["recovered"] and first["segments"][0]["radius_mm"] == 4.0
    kinds = [e["type"] for e in sim.events() if e["event"] == "message"]
    assert kinds[0] == "HELLO" and "HEARTBEAT" in kinds
    (hb,) = [e for e in sim.events() if e.get("type") == "HEARTBEAT"][-1:]
    assert hb["ack_mode"] == ack_mode


def sim_wait(sim, predicate, timeout_s=10.0):
    return wait_until(lambda: predicate(sim.obstacles()), timeout_s)


def test_unplug_and_replug_loses_only_what_was_sent_meanwhile(bridge, tmp_path, start_sim):
    sim = start_sim(bridge.sim_path, tmp_path / "sim.jsonl", "-q")
    link = ArmLink(serial_cfg(bridge.link_path), np.eye(4)).open()
    marks = {}

    def plug(i):
        if i == 30:
            marks["unplug"] = time.monotonic()
            bridge.unplug()
        elif i == 45:
            bridge.replug()
        elif i > 45 and "back" not in marks and link.stats()["connects"] == 2:
            marks["back"] = time.monotonic()

    times, longest = submit_paced(link, range(100), 0.01, plug)
    assert sim_wait(sim, lambda obs: obs and obs[-1]["frame_seq"] == 99), (link.stats(), marks)
    stats = link.stats()
    link.close()
    sim.stop()
    got = [o["frame_seq"] for o in sim.obstacles()]
    context = {"got": got, "stats": stats, "longest_s": longest,
               **{k: v - times[0] for k, v in marks.items()}}
    assert got == sorted(set(got)), context  # in order, no duplicates
    lost = set(range(100)) - set(got)
    window = (marks["unplug"] - 0.1, marks["back"])  # bytes in the pty when it went are lost too
    assert lost and all(window[0] <= times[i] <= window[1] for i in lost), context
    assert stats["disconnects"] == 1 and stats["connects"] == 2 and longest < 0.1, context
    hellos = [e for e in sim.events() if e.get("type") == "HELLO"]
    assert len(hellos) == 2


def test_wait_for_port_then_connects(tmp_path, start_sim):
    from ptybridge import PtyBridge

    folder = tmp_path / "later"
    folder.mkdir()
    link = ArmLink(serial_cfg(folder / "ttyLINK", wait_for_port=True), np.eye(4)).open()
    for i in range(5):
        link.submit(make_result(i), i)  # queued; the oldest fall out of the queue of 4
    assert not link.stats()["connected"]
    bridge = PtyBridge(folder)
    try:
        sim = start_sim(bridge.sim_path, tmp_path / "sim.jsonl", "-q")
        assert wait_until(lambda: link.stats()["connected"])
        link.submit(make_result(5), 5)
        assert sim_wait(sim, lambda obs: obs and obs[-1]["frame_seq"] == 5)
        stats = link.stats()
        link.close()
        sim.stop()
    finally:
        bridge.close()
    assert stats["dropped"] == 1
    assert [o["frame_seq"] for o in sim.obstacles()][-1] == 5


def test_ack_mode_retransmits_dropped_and_corrupted_frames(bridge, tmp_path, start_sim):
    sim = start_sim(bridge.sim_path, tmp_path / "sim.jsonl", "-q", "--fault", "drop=0.2",
                     "--fault", "corrupt=0.2", "--seed", "3")
    link = ArmLink(serial_cfg(bridge.link_path, ack_mode=True, ack_timeout_s=0.03, max_retries=10),
                   np.eye(4)).open()
    n = 30
    submit_paced(link, range(n), 0.05)
    done = lambda s: s["acked"] + s["gave_up"] + s["superseded"] >= n  # noqa: E731
    assert wait_until(lambda: done(link.stats())), link.stats()
    stats = link.stats()
    link.close()
    sim.stop()
    got = [o["frame_seq"] for o in sim.obstacles()]
    assert got == sorted(got)  # retransmissions repeat a set, never reorder
    # a set is lost only when a newer one replaced it before its ACK (or retries ran out)
    assert len(set(range(n)) - set(got)) <= stats["superseded"] + stats["gave_up"] < n // 3
    assert stats["retransmits"] > 0 and stats["nacked"] > 0 and stats["gave_up"] == 0
    errors = [e for e in sim.events() if e["event"] == "error"]
    assert errors and {e["reason"] for e in errors} == {"bad_crc"}


def test_write_timeout_when_nobody_reads_never_blocks_the_caller(tmp_path):
    master, slave = os.openpty()
    path = os.ttyname(slave)
    link = ArmLink(serial_cfg(path, write_timeout_s=0.5, queue_results=2), np.eye(4)).open()
    longest = 0.0
    big = make_result(0)
    try:
        for i in range(400):  # nobody reads the master: the pty buffer fills
            t0 = time.monotonic()
            link.submit(big, i)
            longest = max(longest, time.monotonic() - t0)
            time.sleep(0.002)
        assert wait_until(lambda: link.stats()["write_timeouts"] > 0)
        # a reader appears: frames decode again after the 0x00 that follows a timed-out write
        os.set_blocking(master, False)
        dec = P.FrameDecoder()
        frames = []
        for i in range(400, 420):
            link.submit(big, i)
            time.sleep(0.01)
            try:
                frames += dec.feed(os.read(master, 1 << 16))
            except BlockingIOError:
                pass
        assert wait_until(lambda: link.stats()["queued"] == 0)
        try:
            frames += dec.feed(os.read(master, 1 << 16))
        except BlockingIOError:
            pass
        seqs = [P.parse(f).frame_seq for f in frames if isinstance(f, P.Frame) and f.type == P.OBSTACLES]
        assert seqs and seqs[-1] == 419
    finally:
        stats = link.stats()
        link.close()
        os.close(master)
        os.close(slave)
    assert longest < 0.2 and stats["dropped"] > 0 and stats["connected"] is True


def test_a_result_that_cannot_be_sent_does_not_stop_the_link():
    master, slave = os.openpty()
    link = ArmLink(serial_cfg(os.ttyname(slave)), np.eye(4)).open()
    try:
        link.submit(object(), 0)  # not a LocalizationResult
        assert wait_until(lambda: link.stats()["errors"] == 1)
        link.submit(make_result(1), 1)
        dec, seqs = P.FrameDecoder(), []
        os.set_blocking(master, False)

        def got_it():
            try:
                frames = dec.feed(os.read(master, 1 << 16))
            except BlockingIOError:
                return False
            seqs.extend(P.parse(f).frame_seq for f in frames if isinstance(f, P.Frame) and f.type == P.OBSTACLES)
            return 1 in seqs

        assert wait_until(got_it)
        assert "AttributeError" in link.stats()["last_error"]
    finally:
        link.close()
        os.close(master)
        os.close(slave)
    assert seqs == [1]
