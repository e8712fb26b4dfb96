"""numba compiling its kernels (a cache miss: the first command after an install or a change of a
kernel), as `vcnc run` and `vcnc fit` tell the user: why nothing happens yet, how long it took, and
that `vcnc warmup` does it once, ahead (it takes 1.5-2 minutes of CPU).

numba is imported only when a command starts watching (a module that imports numba at its top is
a kernel module for ipo.kernel_cache, and every edit of one would recompile every kernel)."""
from __future__ import annotations

import os
import time


class Compiling:
    """Watches numba compile its kernels in this process (a worker it forks runs the listener too, and
    is not counted), so a progress display can say why nothing moves yet (on_change) and the summary
    how much of the wall time it took."""

    RUNNING = "running"
    COMPILING = "compiling numba kernels (first run only, cached afterwards)"
    AHEAD = "`vcnc warmup` compiles them once, ahead"

    def __init__(self):
        from numba.core import event

        self._event = event
        self.pid = os.getpid()
        self.depth, self.t0, self.total_s = 0, 0.0, 0.0
        self.on_change = lambda compiling: None
        self.listener = type("L", (event.Listener,), {"on_start": lambda _, ev: self._start(),
                                                       "on_end": lambda _, ev: self._end()})()

    def _start(self):
        if os.getpid() != self.pid:
            return
        self.depth += 1
        if self.depth == 1:  # a kernel that calls others compiles them inside its own compile
            self.t0 = time.perf_counter()
            self.on_change(True)

    def _end(self):
        if os.getpid() != self.pid:
            return
        self.depth -= 1
        if self.depth == 0:
            self.total_s += time.perf_counter() - self.t0
            self.on_change(False)

    def summary(self, what: str) -> str | None:
        """The closing line where numba compiled (what: "run", "fit"), else None."""
        if self.total_s <= 0:
            return None
        return (f"numba compiled its kernels for {self.total_s:.1f} s of this {what}'s wall time (first {what} after an"
                f" install or a change; cached for the next ones; {self.AHEAD})")

    def __enter__(self):
        self._event.register("numba:compile", self.listener)
        return self

    def __exit__(self, *exc):
        self._event.unregister("numba:compile", self.listener)
