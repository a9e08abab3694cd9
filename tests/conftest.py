"""Shared test helpers: paths of the repository and its fixtures, the compiled kernels, the rendered scenes.

Under pytest-xdist (``pytest -n 2``: the suite on two processes; ``--dist loadfile`` is in pyproject.toml's
``addopts``: a file's tests, which mostly share their seeds, run on one process) the work both processes would
otherwise repeat is shared through the session's common temporary directory: each kernels module is compiled by
whichever process comes to it first (the other loads it from numba's disk cache), each rendered scene is
rendered once and read by the other process from a pickle."""

from __future__ import annotations

import fcntl
import os
import pickle
from contextlib import contextmanager
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "fixtures"


@pytest.fixture
def repo() -> Path:
    return REPO


def _worker() -> int | None:
    """This process's number under pytest-xdist (0, 1, ...), None when the suite runs in one process."""
    name = os.environ.get("PYTEST_XDIST_WORKER")
    return int(name.removeprefix("gw")) if name else None


@pytest.fixture(scope="session")
def _shared_dir(tmp_path_factory) -> Path | None:
    """A directory common to the session's processes (None in a single process)."""
    if _worker() is None:
        return None
    shared = tmp_path_factory.getbasetemp().parent / "shared"      # the workers' base temps' common parent
    shared.mkdir(exist_ok=True)
    return shared


@contextmanager
def _exclusive(path: Path):
    """Held by one process of the session at a time (an advisory lock on ``path``, released on exit)."""
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


@pytest.fixture(scope="session", autouse=True)
def _compiled_kernels(_shared_dir):
    """Compile the localizer's numba kernels into their disk cache once, before the first test: the first
    compile takes about 3 min of CPU, and must not eat the deadline of a test that starts `appliance` as a
    process (those then load the kernels from the cache in about 2 s).

    Under xdist each kernels module is compiled under a lock, the workers taking the modules from opposite
    ends of the list: a module is compiled by one process (numba's cache writes are atomic renames, but two
    processes adding signatures of one function at once could each number its entry 1), the other loads it."""
    from appliance.localize import kernels

    if _shared_dir is None:
        kernels.warm_up()
        return
    modules = kernels.kernel_modules()
    for module in (modules if _worker() % 2 == 0 else modules[::-1]):
        with _exclusive(_shared_dir / f"warm_{module.__name__}.lock"):
            module.warm_up()


@pytest.fixture(scope="session")
def rendered_scene(_shared_dir):
    """A function: seed -> (left, right, truth, calibration) of the accuracy benchmark's rendered scene of that
    seed (2x2 supersamples, as the benchmark's cache), each rendered once per session (~5-10 s each; under
    xdist by the first process that needs it, the others read its pickle)."""
    from functools import lru_cache

    from appliance.synth.rig import default_rig
    from appliance.synth.scene import make_scene, render
    rig = default_rig()

    def rendered(seed: int):
        return render(make_scene(seed), rig, seed=seed, ss=2)

    def shared(seed: int):
        path = _shared_dir / f"scene_{seed}.pickle"
        with _exclusive(path.with_suffix(".lock")):
            if path.exists():
                return pickle.loads(path.read_bytes())
            out = rendered(seed)
            tmp = path.with_suffix(".tmp")
            tmp.write_bytes(pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL))
            tmp.replace(path)
            return out

    @lru_cache(maxsize=None)
    def scene(seed: int):
        left, right, truth = (rendered if _shared_dir is None else shared)(seed)
        return left, right, truth, rig.calibration()
    return scene


# The tests that wait for real time (rates, deadlines, signals, a killed writer's last second) or hold real
# devices (pseudo-terminals, the GigE fake camera): `make test` runs them on their own after the rest, which runs
# on two processes (README, "Test time"). Entries are node-id prefixes under tests/: a file, or a file's tests
# whose names start so. Tests that only start processes and check what they wrote run with the rest.
SERIAL = ("acquire/test_fake.py", "acquire/test_v4l2.py", "acquire/test_gige.py", "appliance/test_live.py",
          "appliance/test_run.py::test_a_signal_finishes", "appliance/test_run.py::test_sigkill",
          "appliance/test_run.py::test_a_camera_faster", "appliance/test_run.py::test_a_lost_camera",
          "arm/test_link.py", "arm/test_sim.py", "arm/test_run_e2e.py",
          "logs/test_crash.py", "logs/test_disk.py", "logs/test_replay.py")


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Mark the tests of :data:`SERIAL` ``serial`` (before ``-m`` selects by marks)."""
    prefixes = tuple(f"tests/{entry}" for entry in SERIAL)
    for item in items:
        if item.nodeid.startswith(prefixes):
            item.add_marker(pytest.mark.serial)
