"""End to end: `appliance run --device fake:... --serial PTY` delivers every result to `arm-sim`."""

from __future__ import annotations

import subprocess

import numpy as np

from armtest import APPLIANCE, REPO_FIXTURES


def test_run_delivers_every_result_to_arm_sim_in_order(bridge, tmp_path, start_sim):
    sim = start_sim(bridge.sim_path, tmp_path / "sim.jsonl", "-q")
    run = subprocess.run([str(APPLIANCE), "run", "--device", f"fake:{REPO_FIXTURES / 'scenes'}",
                          "--calib", str(REPO_FIXTURES / "rig.yaml"), "--no-log", "--serial",
                          str(bridge.link_path), "-q"], capture_output=True, text=True, timeout=180)
    assert run.returncode == 0, run.stderr
    n = len(list((REPO_FIXTURES / "scenes").glob("left_*.png")))
    sim.wait_for(lambda evs: sum(e.get("type") == "OBSTACLES" for e in evs) >= n, f"{n} results")
    sim.stop()
    obs = sim.obstacles()
    assert [o["frame_seq"] for o in obs] == list(range(n))
    assert all(o["segments"] and len(o["segments"]) <= 16 and o["total"] >= len(o["segments"]) for o in obs)
    assert all(o["truncated"] == (o["total"] > len(o["segments"])) for o in obs)
    # nearest first, as PROTOCOL.md defines it (distance of the capsule from the base origin)
    def dist(s):
        a, b = np.array(s["p0_mm"]), np.array(s["p1_mm"])
        t = np.clip(-a @ (b - a) / max((b - a) @ (b - a), 1e-12), 0, 1)
        return max(0.0, np.linalg.norm(a + t * (b - a)) - s["clearance_mm"])

    for o in obs:
        d = [dist(s) for s in o["segments"]]
        assert all(x <= y + 0.5 for x, y in zip(d, d[1:]))
    hellos = [e for e in sim.events() if e.get("type") == "HELLO"]
    assert len(hellos) == 1
