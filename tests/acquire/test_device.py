import pytest

from appliance.acquire import InvalidDevice, parse_device


@pytest.mark.parametrize("text,kind,targets", [
    ("/dev/video0", "v4l2", ("/dev/video0",)),
    ("/dev/video0,/dev/video2", "v4l2", ("/dev/video0", "/dev/video2")),
    ("/dev/v4l/by-id/usb-Stereo_Cam-video-index0", "v4l2", ("/dev/v4l/by-id/usb-Stereo_Cam-video-index0",)),
    ("gige:192.168.1.20", "gige", ("192.168.1.20",)),
    ("gige:127.0.0.1, 127.0.0.2", "gige", ("127.0.0.1", "127.0.0.2")),
    ("gige:cam-left.local", "gige", ("cam-left.local",)),
    ("fake:fixtures/scenes", "fake", ("fixtures/scenes",)),
    ("fake:a,b.mcap", "fake", ("a,b.mcap",)),
])
def test_device_strings(text, kind, targets):
    spec = parse_device(text)
    assert (spec.kind, spec.targets, spec.paired) == (kind, targets, len(targets) == 2)


@pytest.mark.parametrize("text,message", [
    ("video0", "device 'video0': not a device string; expected /dev/videoN | /dev/videoN,/dev/videoM"),
    ("", "device '': not a device string"),
    ("/dev/ttyUSB0", "device '/dev/ttyUSB0': '/dev/ttyUSB0' is not a V4L2 device (/dev/videoN)"),
    ("/dev/video0,/dev/video1,/dev/video2", "give one camera or two separated by a comma"),
    ("/dev/video0,", "give one camera or two"),
    ("/dev/video0,/dev/video0", "left and right name the same camera"),
    ("gige:", "give one camera or two"),
    ("gige:300.1.1.1", "'300.1.1.1' is not an IP address or host name"),
    ("gige:a b", "'a b' is not an IP address or host name"),
    ("fake:", "fake: needs a path"),
])
def test_garbage_is_rejected_in_one_line(text, message):
    with pytest.raises(InvalidDevice) as err:
        parse_device(text)
    assert message in str(err.value) and "\n" not in str(err.value)
