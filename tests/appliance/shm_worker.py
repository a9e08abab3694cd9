"""What a localizer process does with a shared slot, minus the localizer (spawned workers import it
by name: a test module is not importable in them)."""

from appliance.shared_frames import attach, pair_view

_OPEN: dict = {}


def sums(ref):
    """The slot and its two images' sums, read in place."""
    if ref.name not in _OPEN:
        _OPEN[ref.name] = attach(ref.name)
    pair = pair_view(_OPEN[ref.name].buf, ref.slot, ref.shape)
    return ref.slot, int(pair[0].sum()), int(pair[1].sum())
