"""The G-code parser state of the grbl TEST DOUBLE (tests/grbl_emulator.py) -- not grbl.

What grbl 1.1's gcode.c keeps between lines, as far as vcnc's stream uses it: the
machine position the parser holds, G0-G3, F, plane, G20/G21, G90/G91, G54-G59 with
their offsets, G92, G53 (non-modal, G0/G1 only), G10 L2/L20, tool length offset,
M-codes. Positions are machine coordinates; words are work coordinates, offset by
the active work coordinate system + G92 + tool length offset (the WCO). A soft reset
keeps the G54-G59 offsets (grbl's EEPROM) and clears the rest, as gc_init does.
"""
from __future__ import annotations

import math
import re

WORD_RE = re.compile(r"([A-Z])([-+]?(?:\d+\.?\d*|\.\d+))")
COORDS = (54, 55, 56, 57, 58, 59)


class ParserState:
    def __init__(self, offsets: dict[int, list[float]], mpos):
        self.offsets = offsets  # G54..G59 -> machine position of the work zero (kept over resets)
        self.reset(mpos)

    def reset(self, mpos) -> None:
        self.pos = list(mpos)  # machine coordinates
        self.motion, self.feed, self.plane = 0, 0.0, 17
        self.inch, self.incremental, self.coord = False, False, 54
        self.g92, self.tlo = [0.0, 0.0, 0.0], 0.0
        self.spindle, self.coolant, self.tool, self.rpm = "M5", "M9", 0, 0.0

    @property
    def wco(self) -> list[float]:
        o = self.offsets[self.coord]
        return [o[0] + self.g92[0], o[1] + self.g92[1], o[2] + self.g92[2] + self.tlo]

    def modal_report(self) -> str:
        motion = {0: "G0", 1: "G1", 2: "G2", 3: "G3"}[self.motion]
        return (f"[GC:{motion} G{self.coord} G{self.plane} {'G20' if self.inch else 'G21'} "
                f"{'G91' if self.incremental else 'G90'} G94 {self.spindle} {self.coolant} T{self.tool} "
                f"F{self.feed:g} S{self.rpm:g}]")

    def params_report(self) -> list[str]:
        fmt = lambda v: ",".join(f"{x:.3f}" for x in v)  # noqa: E731
        out = [f"[G{c}:{fmt(self.offsets[c])}]" for c in COORDS]
        out += ["[G28:0.000,0.000,0.000]", "[G30:0.000,0.000,0.000]", f"[G92:{fmt(self.g92)}]",
                f"[TLO:{self.tlo:.3f}]", "[PRB:0.000,0.000,0.000:0]"]
        return out

    def parse(self, line: str, mist: bool = True):
        """-> (error code, block or None, non-motion effect or None). A block is
        (target machine mm, arc or None, N). The state changes only when the line is accepted."""
        pos, words, gs, ms = 0, {}, [], []
        for m in WORD_RE.finditer(line):
            if m.start() != pos:
                return 1, None, None
            pos = m.end()
            letter, value = m.group(1), float(m.group(2))
            if letter == "G":
                gs.append(value)
            elif letter == "M":
                ms.append(value)
            elif letter in words:
                return 25, None, None
            elif letter in "XYZIJKFPSTNLR":
                words[letter] = value
            else:
                return 20, None, None
        if pos != len(line):
            return (2 if pos else 1), None, None
        new = dict(motion=self.motion, plane=self.plane, inch=self.inch, incremental=self.incremental,
                   coord=self.coord)
        g53 = g10 = g92 = dwell = False
        for g in gs:
            if g in (0, 1, 2, 3):
                new["motion"] = int(g)
            elif g in (17, 18, 19):
                new["plane"] = int(g)
            elif g in (20, 21):
                new["inch"] = g == 20
            elif g in (90, 91):
                new["incremental"] = g == 91
            elif g in COORDS:
                new["coord"] = int(g)
            elif g == 53:
                g53 = True
            elif g == 10:
                g10 = True
            elif g in (92, 92.1):
                g92 = g
            elif g == 4:
                dwell = True
            elif g not in (91.1, 94, 40, 49, 80):
                return 20, None, None
        for m in ms:
            if m not in (0, 1, 2, 30, 3, 4, 5, 7, 8, 9) or (m == 7 and not mist):
                return 20, None, None
        unit = 25.4 if new["inch"] else 1.0
        feed = words["F"] * unit if "F" in words else self.feed
        axes = {k: words[a] * unit for k, a in enumerate("XYZ") if a in words}
        if dwell:
            if "P" not in words:
                return 28, None, None
            return 0, None, ("dwell", words["P"])
        if g53 and new["motion"] not in (0, 1):
            return 30, None, None
        if g10:
            return self._g10(words, axes)
        if g92 == 92.1:
            self.g92 = [0.0, 0.0, 0.0]
            return 0, None, ("g92.1", None)
        offsets = self.offsets[new["coord"]]
        wco = [offsets[0] + self.g92[0], offsets[1] + self.g92[1], offsets[2] + self.g92[2] + self.tlo]
        if g92 == 92:
            for k, v in axes.items():
                self.g92[k] = self.pos[k] - offsets[k] - v - (self.tlo if k == 2 else 0.0)
            return 0, None, ("g92", None)
        target = list(self.pos)
        for k, v in axes.items():
            target[k] = v if g53 else (self.pos[k] + v if new["incremental"] else v + wco[k])
        arc = None
        if axes and new["motion"] in (1, 2, 3) and not feed:
            return 22, None, None
        if axes and new["motion"] in (2, 3):
            a, b = {17: (0, 1), 18: (2, 0), 19: (1, 2)}[new["plane"]]
            off = "IJK"
            if "XYZ"[a] not in words and "XYZ"[b] not in words:
                return 32, None, None
            if off[a] not in words and off[b] not in words:
                return 35, None, None
            ca = self.pos[a] + words.get(off[a], 0.0) * unit
            cb = self.pos[b] + words.get(off[b], 0.0) * unit
            r0 = math.hypot(self.pos[a] - ca, self.pos[b] - cb)
            r1 = math.hypot(target[a] - ca, target[b] - cb)
            if abs(r0 - r1) > 0.005 and abs(r0 - r1) > 0.001 * r0:
                return 33, None, None
            arc = (a, b, 3 - a - b, ca, cb, new["motion"] == 3)
        self.motion, self.plane, self.inch = new["motion"], new["plane"], new["inch"]
        self.incremental, self.coord, self.feed = new["incremental"], new["coord"], feed
        for m in ms:
            if m in (3, 4, 5):
                self.spindle = f"M{int(m)}"
            elif m in (7, 8, 9):
                self.coolant = f"M{int(m)}"
        if "S" in words:
            self.rpm = words["S"]
        n = int(words["N"]) if "N" in words else None
        if axes:
            self.pos = target
            return 0, (tuple(target), arc, n), None
        return 0, None, (("mcode", ms) if ms else None)

    def _g10(self, words, axes):
        if "L" not in words or "P" not in words or int(words["P"]) not in range(0, 7):
            return 28, None, None
        coord = self.coord if int(words["P"]) == 0 else 53 + int(words["P"])
        o = self.offsets[coord]
        for k, v in axes.items():
            if int(words["L"]) == 2:
                o[k] = v
            elif int(words["L"]) == 20:
                o[k] = self.pos[k] - v - self.g92[k] - (self.tlo if k == 2 else 0.0)
            else:
                return 20, None, None
        return 0, None, ("g10", None)
