"""stop_on_signals: a signal sets the stop event even when it lands while the event's lock is held; a second ends
the process."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap

import pytest

# The child holds the event's own lock (as stop.wait() does) while SIGTERM arrives, then lets go.
# A handler that set the event itself would wait for that lock on the same thread, forever.
CHILD = textwrap.dedent("""
    import os, signal, threading
    from appliance.commands.common import stop_on_signals
    stop = threading.Event()
    stop_on_signals(stop)
    with stop._cond:
        os.kill(os.getpid(), signal.{sig})
        sum(range(1000))          # bytecodes for the handler to run between
    print("stopped" if stop.wait(10) else "not stopped", flush=True)
""")


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT"])
def test_a_signal_inside_the_events_lock_still_stops(sig):
    r = subprocess.run([sys.executable, "-c", CHILD.format(sig=sig)], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "stopped"


def test_other_signals_do_not_stop():
    child = CHILD.replace("stop_on_signals(stop)", "stop_on_signals(stop, (signal.SIGTERM,))\n"
                          "signal.signal(signal.SIGUSR1, lambda *_: None)").replace("stop.wait(10)", "stop.wait(1)")
    r = subprocess.run([sys.executable, "-c", child.format(sig="SIGUSR1")], capture_output=True, text=True,
                       timeout=30)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "not stopped"


def test_a_second_signal_ends_the_process_at_once():
    child = CHILD.replace('print("stopped" if stop.wait(10) else "not stopped", flush=True)',
                          'print("stopped" if stop.wait(10) else "not stopped", flush=True)\n'
                          'os.kill(os.getpid(), signal.{sig})\n'
                          'threading.Event().wait(10)\n'
                          'print("still running", flush=True)')
    r = subprocess.run([sys.executable, "-c", child.format(sig="SIGTERM")], capture_output=True, text=True,
                       timeout=30)
    assert r.returncode == -signal.SIGTERM, (r.returncode, r.stderr)
    assert r.stdout.split() == ["stopped"]
