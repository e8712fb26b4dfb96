"""grbl 1.1's serial protocol as data: response kinds, status reports, error and
alarm meanings, `$$` settings and `$I` build info.

Facts from grbl 1.1's interface documentation (doc/markdown/interface.md,
realtime_cmds.md, doc/csv/*.csv in gnea/grbl). Pure functions; no I/O here.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

RX_BUFFER_DEFAULT = 128  # bytes; `$I` reports the real size on 1.1f and later
PLANNER_BLOCKS_DEFAULT = 15
# grbl stores at most LINE_BUFFER_SIZE-1 = 79 characters of a line (protocol.c); the
# newline makes 80 bytes on the wire.
MAX_LINE_CHARS = 79

WAKE = b"\r\n\r\n"
STATUS_QUERY = b"?"
FEED_HOLD = b"!"
CYCLE_RESUME = b"~"
SOFT_RESET = b"\x18"
FEED_OV_RESET = b"\x90"  # 100 % of the programmed feed
FEED_OV_PLUS_10 = b"\x91"
FEED_OV_MINUS_10 = b"\x92"
FEED_OV_PLUS_1 = b"\x93"
FEED_OV_MINUS_1 = b"\x94"
JOG_CANCEL = b"\x85"
RAPID_OV_RESET = b"\x95"
RAPID_OV_50 = b"\x96"
RAPID_OV_25 = b"\x97"
SPINDLE_OV_RESET = b"\x99"
SPINDLE_OV_PLUS_10 = b"\x9a"
SPINDLE_OV_MINUS_10 = b"\x9b"
REALTIME_BYTES = frozenset(b"?!~\x18") | frozenset(range(0x80, 0x100))

BANNER_RE = re.compile(r"^Grbl (\d+\.\d+[a-z]?) \['\$' for help\]")

ERROR_MEANINGS = {
    1: "G-code words consist of a letter and a value. Letter was not found.",
    2: "Numeric value format is not valid or missing an expected value.",
    3: "Grbl '$' system command was not recognized or supported.",
    4: "Negative value received for an expected positive value.",
    5: "Homing cycle is not enabled via settings.",
    6: "Minimum step pulse time must be greater than 3usec.",
    7: "EEPROM read failed. Reset and restored to default values.",
    8: "Grbl '$' command cannot be used unless Grbl is IDLE.",
    9: "G-code locked out during alarm or jog state.",
    10: "Soft limits cannot be enabled without homing also enabled.",
    11: "Max characters per line exceeded. Line was not processed and executed.",
    12: "Grbl '$' setting value exceeds the maximum step rate supported.",
    13: "Safety door detected as opened and door state initiated.",
    14: "Build info or startup line exceeded EEPROM line length limit.",
    15: "Jog target exceeds machine travel. Command ignored.",
    16: "Jog command with no '=' or contains prohibited g-code.",
    17: "Laser mode requires PWM output.",
    20: "Unsupported or invalid g-code command found in block.",
    21: "More than one g-code command from same modal group found in block.",
    22: "Feed rate has not yet been set or is undefined.",
    23: "G-code command in block requires an integer value.",
    24: "Two G-code commands that both require the use of the XYZ axis words were detected in the block.",
    25: "A G-code word was repeated in the block.",
    26: "A G-code command implicitly or explicitly requires XYZ axis words in the block, but none were detected.",
    27: "N line number value is not within the valid range of 1 - 9,999,999.",
    28: "A G-code command was sent, but is missing some required P or L value words in the line.",
    29: "Grbl supports six work coordinate systems G54-G59. G59.1, G59.2, and G59.3 are not supported.",
    30: "The G53 G-code command requires either a G0 seek or G1 feed motion mode to be active.",
    31: "There are unused axis words in the block and G80 motion mode cancel is active.",
    32: "A G2 or G3 arc was commanded but there are no XYZ axis words in the selected plane to trace the arc.",
    33: "The motion command has an invalid target.",
    34: "A G2 or G3 arc, traced with the radius definition, had a mathematical error when computing the arc geometry.",
    35: "A G2 or G3 arc, traced with the offset definition, is missing the IJK offset word in the selected plane.",
    36: "There are unused, leftover G-code words that aren't used by any command in the block.",
    37: "The G43.1 dynamic tool length offset command cannot apply an offset to an axis other than its configured axis.",
    38: "Tool number greater than max supported value.",
}

ALARM_MEANINGS = {
    1: "Hard limit triggered. Machine position is likely lost; re-homing is highly recommended.",
    2: "G-code motion target exceeds machine travel (soft limit). Machine position retained; may be unlocked.",
    3: "Reset while in motion. Position may be lost; re-homing is highly recommended.",
    4: "Probe fail: the probe is not in the expected initial state.",
    5: "Probe fail: the probe did not contact the workpiece within the programmed travel.",
    6: "Homing fail: reset during the homing cycle.",
    7: "Homing fail: safety door was opened during the homing cycle.",
    8: "Homing fail: the cycle failed to clear the limit switch when pulling off.",
    9: "Homing fail: could not find the limit switch within the search distance.",
}


def error_meaning(code: int) -> str:
    return ERROR_MEANINGS.get(code, f"unknown grbl error code {code}")


def alarm_meaning(code: int) -> str:
    return ALARM_MEANINGS.get(code, f"unknown grbl alarm code {code}")


@dataclass(frozen=True, slots=True)
class Response:
    """One line grbl sent, classified: kind in ok, error, alarm, status, banner,
    setting, feedback, startup, garbage. `code` holds N of error:N / ALARM:N."""

    kind: str
    text: str
    code: int = 0


_ERROR_RE = re.compile(r"^error:(\d+)$")
_ALARM_RE = re.compile(r"^ALARM:(\d+)$")
_SETTING_RE = re.compile(r"^\$(\d+)=(-?[0-9.]+)$")


def classify(raw: bytes) -> Response:
    """Classify one received line (without its line end). Anything unrecognised,
    including bytes that are not ASCII, is 'garbage', never an acknowledgement."""
    try:
        text = raw.decode("ascii").strip()
    except UnicodeDecodeError:
        return Response("garbage", raw.decode("ascii", "replace"))
    if text == "ok":
        return Response("ok", text)
    if m := _ERROR_RE.match(text):
        return Response("error", text, int(m.group(1)))
    if m := _ALARM_RE.match(text):
        return Response("alarm", text, int(m.group(1)))
    if text.startswith("<") and text.endswith(">"):
        return Response("status", text)
    if BANNER_RE.match(text):
        return Response("banner", text)
    if _SETTING_RE.match(text) or text.startswith("$N"):
        return Response("setting", text)
    if text.startswith("[") and text.endswith("]"):
        return Response("feedback", text)
    if text.startswith(">") and (text.endswith(":ok") or ":error:" in text):
        return Response("startup", text)
    return Response("garbage", text)


@dataclass(frozen=True, slots=True)
class Status:
    """A parsed `<...>` status report. Positions in mm (grbl $13=0 assumed).
    mpos/wpos are both filled when a WCO is known (WPos = MPos - WCO)."""

    state: str
    substate: int | None
    mpos: tuple[float, float, float] | None
    wpos: tuple[float, float, float] | None
    wco: tuple[float, float, float] | None
    feed_mm_min: float | None
    spindle_rpm: float | None
    planner_free: int | None
    rx_free: int | None
    line: int | None
    overrides: tuple[int, int, int] | None
    pins: str


class StatusError(ValueError):
    """A status report that does not follow the 1.1 format."""


def _floats(text: str, n: int | None = None) -> tuple[float, ...]:
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError as exc:
        raise StatusError(f"bad numbers {text!r}") from exc
    if n is not None and len(vals) < n:
        raise StatusError(f"expected {n} values in {text!r}")
    return vals


def parse_status(text: str, last_wco: tuple[float, float, float] | None = None) -> Status:
    """Parse a 1.1 status report; `last_wco` fills in the WCO grbl sends only now and then."""
    if not (text.startswith("<") and text.endswith(">")):
        raise StatusError(f"not a status report: {text!r}")
    fields = text[1:-1].split("|")
    state, _, sub = fields[0].partition(":")
    if state not in ("Idle", "Run", "Hold", "Jog", "Alarm", "Door", "Check", "Home", "Sleep"):
        raise StatusError(f"unknown machine state {fields[0]!r}")
    values: dict[str, str] = {}
    for f in fields[1:]:
        key, sep, val = f.partition(":")
        if not sep:
            raise StatusError(f"field without ':' in {text!r}")
        values[key] = val
    mpos = _floats(values["MPos"], 3)[:3] if "MPos" in values else None
    wpos = _floats(values["WPos"], 3)[:3] if "WPos" in values else None
    if mpos is None and wpos is None:
        raise StatusError(f"status report without a position: {text!r}")
    wco = _floats(values["WCO"], 3)[:3] if "WCO" in values else last_wco
    if wco is not None:
        if mpos is not None and wpos is None:
            wpos = tuple(m - o for m, o in zip(mpos, wco))
        elif wpos is not None and mpos is None:
            mpos = tuple(w + o for w, o in zip(wpos, wco))
    feed = spindle = None
    if "FS" in values:
        feed, spindle = _floats(values["FS"], 2)[:2]
    elif "F" in values:
        feed = _floats(values["F"], 1)[0]
    planner_free = rx_free = None
    if "Bf" in values:
        planner_free, rx_free = (int(v) for v in _floats(values["Bf"], 2)[:2])
    ov = tuple(int(v) for v in _floats(values["Ov"], 3)[:3]) if "Ov" in values else None
    return Status(state=state, substate=int(sub) if sub else None, mpos=mpos, wpos=wpos, wco=wco,
                  feed_mm_min=feed, spindle_rpm=spindle, planner_free=planner_free, rx_free=rx_free,
                  line=int(values["Ln"]) if "Ln" in values else None, overrides=ov,
                  pins=values.get("Pn", ""))


def parse_settings(lines: list[str]) -> dict[int, float]:
    """`$$` printout (`$N=value` lines) -> {N: value}."""
    out: dict[int, float] = {}
    for line in lines:
        if m := _SETTING_RE.match(line.strip()):
            out[int(m.group(1))] = float(m.group(2))
    return out


@dataclass(frozen=True, slots=True)
class BuildInfo:
    version: str
    options: str
    planner_blocks: int | None
    rx_buffer_bytes: int | None


def parse_build_info(lines: list[str]) -> BuildInfo:
    """`$I` answer: `[VER:1.1h.20190825:]` and `[OPT:V,15,128]` (blocks, RX bytes since 1.1f)."""
    version, options, blocks, rx = "", "", None, None
    for line in lines:
        line = line.strip()
        if line.startswith("[VER:"):
            version = line[5:-1].split(":")[0]
        elif line.startswith("[OPT:"):
            parts = line[5:-1].split(",")
            options = parts[0]
            if len(parts) >= 3:
                blocks, rx = int(parts[1]), int(parts[2])
    return BuildInfo(version, options, blocks, rx)


def compare_settings(settings: dict[int, float], config, rel_tol: float = 0.01) -> list[str]:
    """Warnings where grbl's $110-$112 (max rate, mm/min) and $120-$122 (acceleration,
    mm/s^2) disagree with the machine configuration the IPO planned with."""
    warnings = []
    for i, axis in enumerate("XYZ"):
        limits = config.axes[i]
        pairs = ((110 + i, "max rate", limits.max_velocity_mm_s * 60.0, "mm/min"),
                 (120 + i, "acceleration", limits.max_accel_mm_s2, "mm/s^2"))
        for key, what, planned, unit in pairs:
            if key not in settings:
                warnings.append(f"grbl did not report ${key} ({axis} {what})")
                continue
            got = settings[key]
            if abs(got - planned) > rel_tol * max(abs(planned), 1e-9):
                side = "lower" if got < planned else "higher"
                warnings.append(f"grbl ${key}={got:g} {unit} ({axis} {what}) is {side} than the machine "
                                f"file's {planned:g} {unit}; the IPO planned with the machine file")
    return warnings
