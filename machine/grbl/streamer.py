"""One stream over a GrblLink: character counting, and stopping it safely.

Streaming keeps the bytes of the lines not yet answered within grbl's RX buffer (the
size `$I` reports, else 128), so grbl always has its next line at hand and never
loses a byte. Anything that stops the stream -- error:N, ALARM:N, or a stop the user
asked for (Ctrl-C, SIGTERM, a closed terminal: `GrblLink.request_stop`) -- goes the
same way: feed hold `!`, wait until grbl reports Hold:0 (decelerated) or stands
still, note its last status, soft-reset it (no alarm: it is not moving) and work out
the resume line from what grbl actually executed:
1. with line numbers (`$I` option N: every line starts with N<seq>), the status's
   `Ln` names the first line still in the planner (the one running, or the next);
2. else the planner blocks still queued (status `Bf`, $10 bit 2): each line makes at
   least one block, so only the last that many motion lines acknowledged (and the
   one the stepper is finishing) may not have run; everything before them has;
3. else the last planner-size + 1 motion lines before the last acknowledgement.
Among those lines the machine position decides (`find_resume`). An `ok` only says
grbl planned a line: before grbl starts the cycle (its RX buffer still holds lines,
its planner is not full) a reset throws away every planned line, so acknowledgements
alone never say what ran.
"""
from __future__ import annotations

import time
from collections import deque
from typing import Callable, Iterable

import serial

from machine.grbl import protocol as P
from machine.grbl.ledger import Fault, Ledger
from machine.grbl.program import StreamLine, resume_text
from machine.grbl.resume import ResumeError, ResumePoint, find_resume


def stream(link, lines: Iterable[StreamLine], ledger: Ledger, result, *,
           resume: ResumePoint | None = None, on_progress: Callable | None = None,
           progress_interval_s: float = 0.1):
    """Send `lines` until all are answered and run, or something stops the stream."""
    it = iter(lines)
    setup: deque[str] = deque()
    nxt = next(it, None)
    if resume is not None and nxt is not None:
        setup.extend(nxt.restore)
        if resume.partial:
            nxt = StreamLine(nxt.seq, nxt.source_line, resume_text(nxt, resume.at_mm), resume.at_mm,
                             nxt.end_mm, True, nxt.restore, nxt.arc, nxt.fmt, nxt.feed_mm_min)
    recent: deque[StreamLine] = deque(maxlen=4 * (link.planner_blocks + 1) + link.rx_size)
    budget = link.rx_size - 1  # grbl 1.1 holds the full size (ring of size+1); some forks hold one less
    t_poll = t_prog = 0.0
    link._last_rx = time.monotonic()
    try:
        while True:
            while (setup or nxt is not None) and not link.stop_requested:  # fill grbl's RX buffer
                seq, text = (0, setup[0]) if setup else (nxt.seq, nxt.text)
                data = text.encode("ascii") + b"\n"
                if len(data) > P.MAX_LINE_CHARS + 1:
                    raise link.error(f"stream line {seq} has {len(data) - 1} characters; grbl takes "
                                     f"{P.MAX_LINE_CHARS}")
                if ledger.waiting_bytes + len(data) > budget:
                    break
                link._write(data)
                ledger.sent(seq, len(data))
                result.rx_fill.append(ledger.waiting_bytes)
                if setup:
                    setup.popleft()
                else:
                    recent.append(nxt)
                    nxt = next(it, None)
            now = time.monotonic()
            draining = nxt is None and not setup and not ledger.waiting
            if now - t_poll >= (link.poll_interval_s / 4 if draining else link.poll_interval_s):
                link._write(P.STATUS_QUERY)
                t_poll = now
            link._flush_realtime()
            idle = False
            for r in link._read():
                if r.kind in ("ok", "error"):
                    seq, _ = ledger.answered(r.kind == "ok", r.code)
                    if r.kind == "error" and result.fault is None:
                        line = next((l for l in recent if l.seq == seq), None)
                        src = line.source_line if line else 0
                        what = f"stream line {seq} (program line {src}, {line.text if line else ''!r})"
                        result.fault = Fault("error", f"grbl error:{r.code} on {what}: "
                                             f"{P.error_meaning(r.code)}", seq, src)
                elif r.kind == "alarm" and (result.fault is None or result.fault.kind != "alarm"):
                    result.fault = Fault("alarm", f"grbl ALARM:{r.code}: {P.alarm_meaning(r.code)} "
                                         f"Clear it with $X (or home, or reset) before resuming.", 0, 0)
                elif r.kind == "banner":
                    result.fault = Fault("alarm", "grbl was reset during the stream (0x18, its reset pin "
                                         "or power)", 0, 0)
                    ledger.discard_waiting()
                elif r.kind == "status" and draining:
                    idle = link.status.state in ("Idle", "Check")  # Check: check mode ran every line
            if result.fault is None and link.stop_requested:
                result.fault = Fault("stopped", f"stopped: {link.stop_requested}", 0, 0)
            if on_progress and now - t_prog >= progress_interval_s:
                on_progress(link, ledger)
                t_prog = now
            if result.fault:
                _stop(link, result, recent)
                return result
            if idle:  # every line answered and the machine has run them all
                result.completed = True
                ledger.resume_from = (recent[-1].seq + 1) if recent else ledger.first
                result.status = link.status
                if on_progress:
                    on_progress(link, ledger)
                return result
            if time.monotonic() - link._last_rx > link.stall_timeout_s:
                result.fault = Fault("stalled", f"grbl stopped answering for {link.stall_timeout_s:g} s", 0, 0)
                _lost(result, recent)
                return result
    except (serial.SerialException, OSError) as exc:
        result.fault = Fault("disconnected", f"the port closed: {exc}", 0, 0)
        _lost(result, recent)
        return result


def _lost(result, recent: deque[StreamLine]) -> None:
    ledger = result.ledger
    ledger.connection_lost = True
    last = ledger.last_acknowledged
    result.fault.seq = last
    result.fault.source_line = next((l.source_line for l in recent if l.seq == last), 0)
    result.fault.message += (f"; last acknowledged stream line {last} (program line "
                             f"{result.fault.source_line}); lines {last + 1}..{ledger.last_sent} "
                             f"were sent without an answer. Reconnect and resume with "
                             f"--resume (or --resume-from {last + 1}): vcnc checks where the machine stands first.")


def _hold(link, ledger: Ledger) -> P.Status | None:
    """Feed hold; read answers until grbl stands still (Hold:0, Idle or Alarm) and the
    answers for lines it had already taken have arrived. Returns its last status then."""
    link._write(P.FEED_HOLD)
    t_end = time.monotonic() + link.reset_timeout_s + link.hold_timeout_s
    t_poll = t_answer = 0.0
    still = None
    while time.monotonic() < t_end:
        now = time.monotonic()
        if still is not None and (not ledger.waiting or now - t_answer > link.settle_s):
            break  # lines grbl holds back until the planner empties will never be answered
        if now - t_poll >= link.poll_interval_s / 4:
            link._write(P.STATUS_QUERY)
            t_poll = now
        for r in link._read():
            if r.kind in ("ok", "error") and ledger.waiting:
                ledger.answered(r.kind == "ok", r.code)
                t_answer = time.monotonic()
            elif r.kind == "status":
                st = link.status
                if st.state in ("Idle", "Alarm", "Check") or (st.state == "Hold" and st.substate == 0):
                    if still is None:
                        t_answer = max(t_answer, time.monotonic())
                    still = st
    return still


def window(recent: list[StreamLine], last_ok: int, held: P.Status | None, planner_blocks: int,
           stepper: int) -> list[StreamLine]:
    """The lines that may not have run when grbl stood still (see the module's steps);
    `last_ok` the last line acknowledged in an unbroken run of oks. `held` is None where
    the planner's content is unknown (an alarm empties it, a killed session never saw it). grbl
    drops a block from its planner once the stepper has taken all of it, before the
    motion ends: the running line may be one before what `Ln` names and one more than
    `Bf` counts; `stepper` = 1 widens the window by that line. (Only where the machine
    is on none of the narrower window's lines: a closed path that ran would be taken
    for one not started.)"""
    if held is not None and held.line is not None:
        idx = next((i for i, l in enumerate(recent) if l.seq >= held.line), len(recent))
        queued = stepper
    else:
        idx = next((i for i, l in enumerate(recent) if l.seq > last_ok), len(recent))
        queued = planner_blocks + 1
        if held is not None and held.planner_free is not None:
            queued = planner_blocks - held.planner_free + stepper
    motions = 0
    while idx > 0 and motions < queued:
        idx -= 1
        motions += recent[idx].motion
    return recent[idx:]


def _stop(link, result, recent: deque[StreamLine]) -> None:
    """Hold, let the answers for lines grbl already has arrive, reset once still, find the resume line."""
    ledger = result.ledger
    result.before_hold = link.status_at_stop or link.status
    held = _hold(link, ledger)
    result.held = held
    link.soft_reset(ledger)
    st = link.query_status()
    result.status = st
    if st.mpos is None:
        raise link.error("grbl gave no machine position after the reset")
    # an alarm resets grbl by itself: its planner was thrown away, Bf and Ln say nothing then
    known = None if result.fault.kind == "alarm" else held
    try:
        try:
            lines = window(list(recent), ledger.last_acknowledged, known, link.planner_blocks, 0)
            result.resume = find_resume(lines, st.mpos) if lines else \
                ResumePoint(ledger.last_acknowledged + 1, False, st.mpos)
        except ResumeError:
            lines = window(list(recent), ledger.last_acknowledged, known, link.planner_blocks, 1)
            result.resume = find_resume(lines, st.mpos)
    except ResumeError as exc:
        result.fault.message += f"; {exc}"
        return
    ledger.resume_from = result.resume.seq
    if result.fault.kind == "error" and 0 < result.fault.seq < result.resume.seq:
        # grbl goes on with the lines already in its buffer after an error: character
        # counting cannot take them back, and the hold may come too late to stop them
        result.fault.message += (f"; WARNING: grbl ran stream lines {result.fault.seq + 1}.."
                                 f"{result.resume.seq - 1} after rejecting line {result.fault.seq}, so "
                                 f"that line's motion was not made")
    if held is not None and result.before_hold is not None and result.before_hold.mpos and held.mpos:
        d = sum((a - b) ** 2 for a, b in zip(held.mpos, result.before_hold.mpos)) ** 0.5
        result.fault.message += (f"; the feed hold stopped the machine {d:.3f} mm past the last position "
                                 f"reported before it ({result.before_hold.state})")
    w = st.wpos or st.mpos
    result.fault.message += (f"; machine stopped at X{w[0]:.3f} Y{w[1]:.3f} Z{w[2]:.3f} (work), "
                             f"resume with --resume (or --resume-from {result.resume.seq})")
