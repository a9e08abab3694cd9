"""`appliance devices` on a sysfs tree made here (CI has no camera), and its --probe error paths,
run as the installed executable."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from appliance.acquire.listing import list_v4l2_devices

APPLIANCE = str(Path(sys.executable).with_name("appliance"))


def fake_sysfs(tmp_path: Path) -> tuple[Path, Path]:
    """Two UVC nodes of one stereo camera and a second camera (video10), as the kernel lays them out."""
    sys_root = tmp_path / "sys"
    drivers = sys_root / "bus" / "usb" / "drivers" / "uvcvideo"
    drivers.mkdir(parents=True)
    usb = sys_root / "devices" / "usb1" / "1-1:1.0"
    usb.mkdir(parents=True)
    (usb / "driver").symlink_to(drivers)
    v4l = sys_root / "class" / "video4linux"
    for name, index, card in [("video10", 0, "Other Cam"), ("video0", 0, "Stereo Cam: USB"), ("video1", 1, "Stereo Cam: USB")]:
        node = v4l / name
        node.mkdir(parents=True)
        (node / "name").write_text(card + "\n")
        (node / "index").write_text(f"{index}\n")
        (node / "device").symlink_to(usb)
    (v4l / "notes").mkdir()  # not a video node
    dev = tmp_path / "dev"
    dev.mkdir()
    (dev / "video0").write_bytes(b"")  # exists, but is no V4L2 device: the format query fails
    return v4l, dev


def test_list_from_sysfs(tmp_path):
    v4l, dev = fake_sysfs(tmp_path)
    devices = list_v4l2_devices(v4l, dev)
    assert [d.node for d in devices] == [str(dev / "video0"), str(dev / "video1"), str(dev / "video10")]
    assert [(d.name, d.driver, d.index) for d in devices] == [
        ("Stereo Cam: USB", "uvcvideo", 0), ("Stereo Cam: USB", "uvcvideo", 1), ("Other Cam", "uvcvideo", 0)]
    assert devices[0].formats == () and "Inappropriate ioctl for device" in devices[0].problem
    assert "No such file or directory" in devices[1].problem
    assert list_v4l2_devices(tmp_path / "absent", dev) == []


def run(*args):
    return subprocess.run([APPLIANCE, "devices", *args], capture_output=True, text=True, timeout=60)


def test_devices_command_lists_and_says_when_there_are_none(tmp_path):
    v4l, dev = fake_sysfs(tmp_path)
    out = run("--sysfs", str(v4l), "--dev", str(dev))
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == f"{dev}/video0  Stereo Cam: USB  (uvcvideo, node index 0)"
    assert lines[1].startswith(f"    formats unknown: {dev}/video0: Inappropriate ioctl")
    assert lines[-2] == f"{dev}/video10  Other Cam  (uvcvideo, node index 0)"
    none = run("--sysfs", str(tmp_path / "nothing"))
    assert none.returncode == 0
    assert none.stdout == f"no V4L2 video devices on this machine ({tmp_path / 'nothing'} is empty or missing)\n"


def test_probe_errors_are_one_line(tmp_path):
    out = run("--probe", "/dev/video9")
    assert out.returncode == 1 and out.stdout == ""
    assert out.stderr.startswith("error: /dev/video9: no such device") and out.stderr.count("\n") == 1
    out = run("--probe", "video9")
    assert out.returncode == 1
    assert out.stderr.startswith("error: device 'video9': not a device string; expected /dev/videoN")


def test_probe_a_fake_folder(pair_folder):
    out = run("--probe", f"fake:{pair_folder}")
    assert out.returncode == 0, out.stderr
    assert f"fake:{pair_folder}: fake, 96x64 BGR8 per camera, 10 Hz" in out.stdout
    assert "pair 0: left (64, 96, 3), right (64, 96, 3)" in out.stdout
