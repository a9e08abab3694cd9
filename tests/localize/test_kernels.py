"""kernels.warm_up (localize/kernels.py): after it, localizing compiles no new signature of any kernel."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

# Run in a fresh process: in this one, earlier tests may have compiled a signature warm_up misses.
PROBE = """
import importlib, json, pkgutil, sys
import cv2
from numba.core.registry import CPUDispatcher
import appliance.localize as L
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.synth.truth import load_truth

fixtures = sys.argv[1]
calib, cfg = load_calibration(fixtures + "/rig.yaml"), load_config().localize
improved, paper = L.Localizer(calib, cfg, "improved"), L.Localizer(calib, cfg, "paper")   # each warms up
modules = [importlib.import_module("appliance.localize." + m.name) for m in pkgutil.iter_modules(L.__path__)
           if m.name.startswith("kernels_")]
kernels = {m.__name__ + "." + k: f for m in modules for k, f in vars(m).items()
           if isinstance(f, CPUDispatcher) and f.__module__ == m.__name__}
before = {k: set(f.signatures) for k, f in kernels.items()}
features = 0
for n in ("00", "01", "02", "03"):
    left, right = (cv2.imread(f"{fixtures}/scenes/{s}_{n}.png") for s in ("left", "right"))
    truth = load_truth(f"{fixtures}/scenes/truth_{n}.json")
    for loc in (improved, paper):
        features += len(loc.localize(left, right).features)
        features += len(loc.localize(left, right, mask_left=truth.mask_left, mask_right=truth.mask_right).features)
new = {k: [str(s) for s in set(f.signatures) - before[k]] for k, f in kernels.items()}
print(json.dumps({"modules": len(modules), "kernels": len(kernels), "warmed": sum(map(bool, before.values())),
                  "features": features, "new": {k: v for k, v in new.items() if v}}))
"""


def test_warm_up_compiles_every_signature_the_localizer_uses():
    """A fresh process builds both Localizers (each warms every kernels_* module up), then localizes the four
    fixtures with both mask sources: no kernel of any module gets a new signature, so no frame waits for numba
    (a live stream's first result, a worker's first pair)."""
    run = subprocess.run([sys.executable, "-c", PROBE, str(REPO / "fixtures")], capture_output=True, text=True,
                         timeout=600, check=True)
    probe = json.loads(run.stdout.strip().splitlines()[-1])
    assert probe["modules"] >= 18 and probe["kernels"] >= 150     # the scan found the kernels modules
    assert probe["warmed"] >= 80 and probe["features"] >= 100     # warm_up compiled them; the localizers ran
    assert probe["new"] == {}


def test_warm_up_lists_every_kernels_module_with_a_warm_up():
    """kernels.kernel_modules (what warm_up and the test session's shared warm-up compile) names every
    ``kernels_<topic>`` module of the package that has a ``warm_up``, each once (kernels_stats has none: its
    helpers are compiled into the kernels that call them)."""
    import importlib
    import pkgutil

    import appliance.localize as L
    from appliance.localize import kernels

    names = [m.__name__.rsplit(".", 1)[1] for m in kernels.kernel_modules()]
    found = [m.name for m in pkgutil.iter_modules(L.__path__) if m.name.startswith("kernels_")]
    assert len(found) >= 19 and len(names) == len(set(names))
    assert set(names) == {n for n in found if hasattr(importlib.import_module("appliance.localize." + n), "warm_up")}
