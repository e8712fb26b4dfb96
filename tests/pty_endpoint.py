"""PtyEndpoint: an Endpoint (machine.increments.receiver) served on the master side of a pty
pair, for tests that drive vcnc's links over a serial device as against a real board (the
increment receiver, the grbl test double)."""
from __future__ import annotations

import os
import tty

from machine.increments.receiver import Endpoint


class PtyEndpoint(Endpoint):
    """The receiver on a pty's master side; `port` is the slave device to open."""

    def __init__(self, target, mangle=None):
        super().__init__(target, mangle)
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.port = os.ttyname(self.slave)

    def _run(self):
        while not self._stop.is_set():
            self._pump(self.master, lambda: os.read(self.master, 65536), lambda b: os.write(self.master, b))
        os.close(self.master)
        os.close(self.slave)
