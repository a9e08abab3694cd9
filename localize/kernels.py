"""The localizer's compiled loops (numba): their shared jit options and :func:`warm_up` (docs/localize-numba.md,
"Module layout" for which module holds which kernels).

Each kernel replaces a stretch of small numpy calls (10-40 per piece or end, ~1-3 us each) by one
compiled loop over the pieces, queries or points: the same rules and, where the arithmetic allows,
the same values. The kernels live in the ``kernels_<topic>`` modules, each named for what its kernels
do; every one of them takes :data:`_JIT` from here (this module imports none of them at import time,
so there is no import cycle).

Compiled on first use and cached on disk: under ``NUMBA_CACHE_DIR`` if set, else beside the modules in
``__pycache__``, else in the user's cache directory (``~/.cache/numba``); later processes load the cache
(~2 s). Where none is writable, in memory in each process (:func:`_cacheable`).
"""

from __future__ import annotations

import warnings

import numba
import numpy as np

def _probe():
    """(A function of this file for :func:`_cacheable`.)"""


def _cacheable() -> bool:
    """Whether numba has a writable place for this file's compiled code (``NUMBA_CACHE_DIR``, else
    beside the file, else the user's cache directory). Where it has none (a read-only install, an
    unwritable home) ``cache=True`` would raise at import: the kernels then compile in memory in each
    process (~170 s on first use), with a warning."""
    try:
        numba.njit(cache=True)(_probe)
        return True
    except RuntimeError:
        warnings.warn(f"numba has no writable cache directory for {__file__} (set NUMBA_CACHE_DIR to one): "
                      "the localizer's kernels compile in memory in each process (~3 min on first use)",
                      RuntimeWarning, stacklevel=2)
        return False


_JIT = dict(cache=_cacheable(), nogil=True)


def _readonly(a: np.ndarray) -> np.ndarray:
    """``a`` made read-only in place (the argument type callers pass for cached tables), for the warm-ups."""
    a.setflags(write=False)
    return a


def kernel_modules() -> tuple:
    """The ``kernels_<topic>`` modules in the order :func:`warm_up` compiles them (imported here, not at import
    time: they import this module for :data:`_JIT`)."""
    from appliance.localize import (kernels_check, kernels_colruns, kernels_dense, kernels_endreads, kernels_fit,
                                    kernels_forkglue, kernels_forknear, kernels_forks, kernels_front, kernels_graph,
                                    kernels_match,
                                    kernels_ncc, kernels_patchshare, kernels_points, kernels_refine, kernels_runs,
                                    kernels_segclean, kernels_segment, kernels_stubs, kernels_tips, kernels_walks)
    # the costliest (dense, after the two it calls most; graph; match) first, half of the ~170 s of CPU of a cold
    # compile: two processes taking the list from opposite ends (tests/conftest.py) meet about halfway
    return (kernels_fit, kernels_runs, kernels_dense, kernels_graph, kernels_match, kernels_walks, kernels_segment,
            kernels_ncc, kernels_tips, kernels_forks, kernels_stubs, kernels_refine, kernels_front, kernels_check,
            kernels_forkglue, kernels_segclean, kernels_endreads, kernels_patchshare, kernels_colruns,
            kernels_points, kernels_forknear)


def warm_up() -> None:
    """Compile (or load from the disk cache) every kernel for the argument types the localizer
    passes, on tiny inputs: ~170 s of CPU the first time without a cache, ~2 s from the cache, then
    nothing. :class:`~appliance.localize.Localizer` calls it when built, so that no frame waits
    for a compile (a live stream, a worker process). Each module's ``warm_up``, in the order of
    :func:`kernel_modules`."""
    for module in kernel_modules():
        module.warm_up()
