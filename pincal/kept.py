"""What pincal keeps between calls, in one place and by one rule.

A script that evaluates many plans one call at a time (``rho0``, ``accuracy``, a region's samples)
should pay once for what does not change between the calls: the Jacobian engine of a parameter set,
the test poses' rows and factor, a region's samples, an accuracy report's configurations. Each such
store is a :class:`Kept` declared here, so a maintainer finds every cache of the package in this
file, and every one follows one keying rule:

* a value is kept for its **owners**, the objects it was computed from (a parameter set, a robot,
  an instrument), compared by identity and held while the value is kept (so that an ``id`` is never
  reused meanwhile), and a **key** of plain values (numbers, strings, the bytes of arrays: an array
  changed in place is a new key, so nothing kept goes stale);
* a store holds the ``size`` values most recently used;
* a store is per thread (nothing to lock on the hot path; each worker thread keeps its own), or
  shared by every thread under a lock (``shared``: values costly to make and read-only).

Imports nothing but the standard library.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any, Generic, TypeVar

__all__ = ["CRITERIA", "ENGINES", "PROBLEMS", "REGIONS", "REPORTS", "STORES", "Kept", "forget_all"]

V = TypeVar("V")


class Kept(Generic[V]):
    """The ``size`` values most recently used of one kind (see the module doc for the rule).

    Args:
        name: what is kept, in words (for :data:`STORES` and tests).
        size: values kept (the least recently used is dropped first).
        shared: one store for every thread, under a lock (default: one per thread).
    """

    def __init__(self, name: str, size: int, *, shared: bool = False) -> None:
        self.name, self.size = name, size
        self._local = threading.local()
        self._lock = threading.Lock() if shared else None
        self._shared: OrderedDict[tuple, tuple[tuple[object, ...], V]] = OrderedDict()
        STORES[name] = self

    def get(self, owners: tuple[object, ...], key: Hashable, build: Callable[[], V]) -> V:
        """The value kept for ``owners`` (by identity) and ``key`` (by equality), or ``build()``'s,
        then kept as the most recently used.

        The owners' ids stand for them: a value kept holds its owners, so no other object can
        have their ids while it is kept."""
        full = (id(owners[0]), key) if len(owners) == 1 else (*map(id, owners), key)
        if self._lock is not None:
            return self._get_shared(full, owners, build)
        try:
            store = self._local.store
        except AttributeError:
            store = self._local.store = OrderedDict()
        found = store.get(full)
        if found is not None:
            store.move_to_end(full)
            return found[1]
        value = build()
        if len(store) >= self.size:
            store.popitem(last=False)
        store[full] = (owners, value)
        return value

    def _get_shared(self, full: tuple, owners: tuple[object, ...], build: Callable[[], V]) -> V:
        """:meth:`get` from the store every thread shares (built outside the lock)."""
        with self._lock:  # type: ignore[union-attr]  # a shared store has its lock
            found = self._shared.get(full)
            if found is not None:
                self._shared.move_to_end(full)
                return found[1]
        value = build()
        with self._lock:  # type: ignore[union-attr]
            if full not in self._shared and len(self._shared) >= self.size:
                self._shared.popitem(last=False)
            self._shared[full] = (owners, value)
        return value

    def drop(self, owners: tuple[object, ...], key: Hashable) -> None:
        """Drop the value kept for ``owners`` and ``key``, if any (this thread's, or the shared one)."""
        full = (id(owners[0]), key) if len(owners) == 1 else (*map(id, owners), key)
        if self._lock is None:
            getattr(self._local, "store", {}).pop(full, None)
        else:
            with self._lock:
                self._shared.pop(full, None)

    def forget(self) -> None:
        """Drop the values kept (this thread's, or the shared ones)."""
        if self._lock is None:
            self._local.__dict__.pop("store", None)
        else:
            with self._lock:
                self._shared.clear()


STORES: dict[str, Kept] = {}
"""Every store of the package, by name."""

ENGINES: Kept[Any] = Kept("the Jacobian engine of a parameter set (and of an instrument's rows)", 16)
"""Owners: the parameter set (and the instrument); key: what is measured. Read on every evaluation
(:func:`pincal.evaluation.plans.engine_for`)."""

CRITERIA: Kept[Any] = Kept("the test-pose criterion of test poses (their rows and factor)", 8)
"""Owners: the parameter set; key: the test poses' values (or the region's), σ, the aggregate, the
task payload (:func:`pincal.rho0` and its kin, without a prior)."""

REPORTS: Kept[Any] = Kept("an accuracy report's configurations, their Jacobians and criterion", 4)
"""Owners: the parameter set; key: the test poses' values, the draws, σ and the joint limits
(:func:`pincal.accuracy` with an integer seed, without a prior, task payload or instrument)."""

REGIONS: Kept[Any] = Kept("a test region's samples on a robot", 8, shared=True)
"""Owners: the robot; key: the region's kind and values and the joint limits: an equal region made
anew (``rho0(params, plan, around(q0, r))`` in a loop) draws its samples once. Shared by the threads:
the samples are read-only and their draws seeded."""

PROBLEMS: Kept[Any] = Kept("a design's problem, built once per worker thread", 4)
"""No owners; key: the problem spec's key, a random hex string made with the spec (the spec itself
comes to a process worker as a copy, so its key stands for it; one spec's key is never another's).
Read at every start of a design; a design drops its problems when its search ends
(:func:`pincal.planning.multistart.problem`, :func:`pincal.planning.multistart.forget`)."""


def forget_all() -> None:
    """Drop every value kept (this thread's, and the shared ones): for tests and benchmarks."""
    for store in STORES.values():
        store.forget()
