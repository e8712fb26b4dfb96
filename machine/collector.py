"""Python's cyclic garbage collector held while vcnc streams a program or loads its modules.

A check and a run make millions of short-lived objects (entities, a record per motion, the
planner's arrays) that reference counting frees and that form no cycles (a whole check and run
of g1_stellabee1 leaves 15-30 unreachable objects, whatever the program's length); the
collector would only traverse each batch of them while it is alive, promote it and traverse
it again: 0.2 s of stellabee1's 3.3 s of CPU. Loading the modules makes some 100,000 objects
that live as long as the process (numba's registries most of them): the collector traversed
them 2-3 times while they were made and once more after, ~40 ms of every `vcnc run`.
"""
from __future__ import annotations

import gc
from contextlib import contextmanager


@contextmanager
def collector_held():
    """The collector off inside (and as it was afterwards)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def freeze_loaded() -> None:
    """What the process has made so far lives as long as it does (the modules it loaded, the
    checked program's entities the run takes): the collector never traverses it again."""
    gc.freeze()
