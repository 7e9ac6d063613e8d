"""BLAS on one thread where pincal computes.

pincal's matrices are small (tens of parameters): a threaded BLAS only adds overhead, and on a
busy machine its spinning threads make every call many times slower. Parallelism comes from the
design's starts, or from the user's own processes. :func:`single_threaded` limits every BLAS
library loaded in the process to one thread for the duration of a ``with`` block and restores
what it found; it costs about a microsecond when BLAS runs on one thread already (threadpoolctl's
own ``limit`` re-reads every library's state: a few hundred microseconds, more than a whole ρ0).
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager

_LIBRARIES: dict[bool, list] = {}


def _libraries() -> list:
    """The BLAS libraries' controllers (threadpoolctl), found once (again once scipy, which may
    bring its own BLAS, is loaded)."""
    key = "scipy.linalg" in sys.modules
    found = _LIBRARIES.get(key)
    if found is None:
        from threadpoolctl import ThreadpoolController

        found = _LIBRARIES[key] = list(ThreadpoolController().select(user_api="blas").lib_controllers)
    return found


@contextmanager
def single_threaded() -> Iterator[None]:
    """A context in which every BLAS library of the process runs on one thread."""
    changed = []
    for lib in _libraries():
        n = lib.get_num_threads()
        if n != 1:
            lib.set_num_threads(1)
            changed.append((lib, n))
    try:
        yield
    finally:
        for lib, n in changed:
            lib.set_num_threads(n)
