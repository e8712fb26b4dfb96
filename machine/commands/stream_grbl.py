"""`vcnc stream FILE --port URL` to a grbl board: one session, from connecting to the
resume line.

1. Connect (soft reset), read `$$`, `$I` and the machine's state (`?`, `$G`, `$#`).
2. Make the whole stream from that state; refuse what the build cannot take and say
   what depends on a position the program never set, before any motion is sent.
3. Stream with a ledger on disk; Ctrl-C, SIGTERM, SIGHUP (closed terminal) and the
   `s` key stop it safely: feed hold, wait for Hold:0, soft reset, resume line.
`--resume` continues from the ledger (even after SIGKILL); `--resume-from N` names
the line. Either way the stream is recomputed from the state the first session
started from (the ledger's header), so the program means the same thing.
"""
from __future__ import annotations

import signal
import sys
import time

import click

KEYS_HELP = ("space hold/resume, s stop, + / - feed 10 %, 0 feed 100 %, r / R rapid 50 % / 100 %, "
             "> / < spindle 10 %")
STATUS_EVERY_S = 2.0  # a status line this often when stderr is not a terminal


def _progress(console, live, total: int, estimate):
    from rich.text import Text

    from machine.grbl import protocol as P
    from machine.realtime import Keyboard

    kb = Keyboard()
    keymap = {" ": None, "+": P.FEED_OV_PLUS_10, "-": P.FEED_OV_MINUS_10, "0": P.FEED_OV_RESET,
              "r": P.RAPID_OV_50, "R": P.RAPID_OV_RESET, ">": P.SPINDLE_OV_PLUS_10, "<": P.SPINDLE_OV_MINUS_10}
    last_print = [0.0]

    def update(link, ledger):
        for k in kb.keys():
            if k == "s":
                link.request_stop("the s key")
            elif k in keymap:
                held = link.status is not None and link.status.state == "Hold"
                link.realtime(keymap[k] or (P.CYCLE_RESUME if held else P.FEED_HOLD))
        text = status_text(link.status, ledger.last_acknowledged, total, estimate, link)
        if live is not None:
            live.update(Text(text + f"   [{KEYS_HELP}]"))
        elif time.monotonic() - last_print[0] >= STATUS_EVERY_S:
            console.print(text, highlight=False)
            last_print[0] = time.monotonic()
    return kb, update


def status_text(st, acknowledged: int, total: int, estimate=None, link=None) -> str:
    text = f"acknowledged {acknowledged:>7}/{total} lines"
    if st is not None:
        pos = st.wpos or st.mpos
        state = st.state + (f":{st.substate}" if st.substate is not None else "")
        text += f"  {state:<7} X{pos[0]:10.3f} Y{pos[1]:10.3f} Z{pos[2]:10.3f}" + ("" if st.wpos else " (machine)")
        if st.line is not None:
            text += f"  Ln {st.line}"
        if st.planner_free is not None:
            text += f"  planner free {st.planner_free:>2}  rx free {st.rx_free:>3}"
        if st.feed_mm_min is not None:
            text += f"  F {st.feed_mm_min:7.0f}"
        if st.overrides:
            text += f"  Ov {st.overrides[0]}/{st.overrides[1]}/{st.overrides[2]}%"
    if estimate is not None:
        running = st.line if st is not None and st.line is not None else acknowledged
        text += f"  remaining ~{estimate.remaining_s(running):.0f} s"
    return text


def estimate_config(config, planner: str | None, board_settings: dict | None, baud: int):
    """The configuration the estimate plans with: the grbl twin (unless --planner says
    otherwise) with the board's `$$` where it answered them, at the link's baud rate."""
    import dataclasses

    from ipo.grbl_settings import GrblSettingsError, from_values
    from machine.planners import with_planner

    out = with_planner(config, planner or "grbl")
    if board_settings:
        try:
            out = with_planner(out, None, from_values(board_settings, "the board"))
        except GrblSettingsError:
            pass  # a board that does not print every setting: the machine file's stand in (describe says so)
    return dataclasses.replace(out, grbl_baud=int(baud))


def grbl_job(path, config, state, numbered=False, frame_mm=None):
    """The whole stream for a machine in `state`, made before a byte goes out, so a
    program grbl cannot take fails here and not halfway through."""
    from ipr.entities import GCodeError
    from machine.grbl.job import build_job
    from machine.grbl.program import StreamProgramError

    try:
        return build_job(path, config, state, numbered=numbered, frame_mm=frame_mm)
    except GCodeError as err:
        raise click.ClickException(str(err)) from None
    except (StreamProgramError, ValueError) as err:
        raise click.ClickException(str(err)) from None


def _install_stop_signals(link) -> dict:
    """Ctrl-C, SIGTERM and a closed terminal stop the stream safely instead of killing vcnc."""
    names = {signal.SIGINT: "Ctrl-C", signal.SIGTERM: "SIGTERM", signal.SIGHUP: "the terminal closed (SIGHUP)"}
    old = {}
    for sig, name in names.items():
        old[sig] = signal.signal(sig, lambda *_a, _n=name: link.request_stop(_n))
    return old


def _resume_point(link, job, ledger_path, resume_from, session):
    """Where a resumed stream continues: the ledger's resume point, else the machine
    position within the lines the last session may not have run."""
    from machine.grbl.resume import find_resume
    from machine.grbl.streamer import window

    lines = job.lines
    if resume_from is not None:
        return link.resume_point(l for l in lines if l.seq >= resume_from)[0]
    if session.completed is not None:
        raise click.ClickException(f"{ledger_path}: the last stream completed (line {session.completed}); "
                                   f"nothing to resume")
    if session.resume is not None:
        seq = session.resume[0]
        return link.resume_point(l for l in lines if l.seq >= seq)[0]
    # killed outright: grbl ran what it had (connect waited for it to stop); the machine
    # position decides among the lines the planner may have held, up to the last sent
    lines = [l for l in lines if l.seq <= session.last_sent + 1]
    st = link.query_status()
    return find_resume(window(lines, session.last_acknowledged, None, link.planner_blocks, 0), st.mpos)


def stream_grbl(port, baud, file, config, *, resume_from, resume, ledger_path, unlock, poll_hz, estimate_time,
                planner=None):
    from rich.console import Console
    from rich.live import Live
    from rich.text import Text

    from machine.grbl.budget import stream_demand
    from machine.grbl.job import option_problems
    from machine.grbl.journal import Journal, JournalError, default_path, program_hash, read_sessions
    from machine.grbl.ledger import Ledger
    from machine.grbl.link import GrblLink, LinkError
    from machine.grbl.resume import ResumeError

    console = Console(stderr=True, soft_wrap=True)
    ledger_path = ledger_path or default_path(file)
    session = None
    if resume or resume_from is not None:
        try:
            session = read_sessions(ledger_path)[-1]
        except JournalError as err:
            raise click.ClickException(str(err)) from None
        if session.header["sha256"] != program_hash(file):
            raise click.ClickException(f"{ledger_path}: written for another version of {file} (its SHA-256 "
                                       f"differs); the resume line would be wrong")
    try:
        link = GrblLink(port, baud=baud, poll_interval_s=1.0 / poll_hz)
    except Exception as err:  # pyserial raises several types for a bad URL or device
        raise click.ClickException(f"cannot open {port}: {err}") from None
    journal = None
    try:
        info = link.connect(config, unlock=unlock)
        console.print(f"{info.banner}  build {info.build.version} options {info.build.options}  RX "
                      f"{link.rx_size} bytes, {link.planner_blocks} planner blocks", highlight=False)
        start = session.state if session is not None else info.state
        numbered = session.header["numbered"] if session is not None else link.line_numbers
        # a resumed stream means what the first session's did (same start), written in the frame
        # grbl has now (a reset clears G92 and the tool length offset)
        job = grbl_job(file, config, start, numbered, info.state.wco_mm)
        errors, warns = option_problems(job.lines, link.options)
        if errors:
            raise click.ClickException("; ".join(errors))
        w = [p - o for p, o in zip(info.state.mpos_mm, info.state.wco_mm)]
        console.print(f"machine at X{w[0]:.3f} Y{w[1]:.3f} Z{w[2]:.3f} (work, {info.state.coord}; machine "
                      f"X{info.state.mpos_mm[0]:.3f} Y{info.state.mpos_mm[1]:.3f} Z{info.state.mpos_mm[2]:.3f})",
                      highlight=False)
        demand = stream_demand(job.lines, baud=baud, planner_blocks=link.planner_blocks,
                               accel_mm_s2=min(a.max_accel_mm_s2 for a in config.axes))
        for msg in info.warnings + job.warnings + warns + demand.warnings:
            console.print(f"[yellow]warning:[/yellow] {msg}", highlight=False)
        for n in job.notices:
            console.print(f"notice: {n}", highlight=False)
        estimate = None
        if estimate_time:
            from machine.grbl.estimate import JobEstimate
            from machine.planners import describe

            est_config = estimate_config(config, planner, info.settings, baud)
            estimate = JobEstimate.plan(job.groups, est_config, start.mpos_mm)
            console.print(f"job time ({describe(est_config)}): {estimate.total_s:.1f} s", highlight=False)
        point = None
        lines = job.lines
        if session is not None:
            point = _resume_point(link, job, ledger_path, resume_from, session)
            lines = [l for l in lines if l.seq >= point.seq]
            console.print(f"machine at X{point.at_mm[0]:.3f} Y{point.at_mm[1]:.3f} Z{point.at_mm[2]:.3f} "
                          f"(machine): continuing from stream line {point.seq}"
                          + (" (inside it)" if point.partial else ""), highlight=False)
        journal = Journal(ledger_path, {"program": str(file), "sha256": program_hash(file),
                                        "state": start.as_json(), "numbered": numbered,
                                        "first": point.seq if point else 1, "planner_blocks": link.planner_blocks})
        ledger = Ledger(point.seq if point else 1, journal)
        old = _install_stop_signals(link)
        try:
            live = Live(Text(""), console=console, refresh_per_second=5) if console.is_terminal else None
            kb, update = _progress(console, live, job.lines[-1].seq if job.lines else 0, estimate)
            if live is not None:
                with live, kb:
                    result = link.stream(lines, ledger, resume=point, on_progress=update)
            else:
                result = link.stream(lines, ledger, resume=point, on_progress=update)
        finally:
            for sig, handler in old.items():
                signal.signal(sig, handler)
        if result.resume is not None:
            r = result.resume
            journal.event(f"R {r.seq} {int(r.partial)} {r.at_mm[0]!r} {r.at_mm[1]!r} {r.at_mm[2]!r}")
        elif result.completed:
            journal.event(f"C {ledger.resume_from - 1}")
    except (LinkError, ResumeError) as err:
        raise click.ClickException(str(err)) from None
    finally:
        link.close()
        if journal is not None:
            journal.close()
    if result.fault is not None:
        if result.held is not None:
            console.print(f"grbl held at X{(result.held.mpos or (0, 0, 0))[0]:.3f} "
                          f"Y{(result.held.mpos or (0, 0, 0))[1]:.3f} Z{(result.held.mpos or (0, 0, 0))[2]:.3f} "
                          f"(machine) before the reset", highlight=False)
        if result.resume is not None:
            src = next((l.source_line for l in job.lines if l.seq == result.resume.seq), 0)
            console.print(f"resume: vcnc stream {file} --port {port} --resume   (stream line {result.resume.seq}, "
                          f"program line {src}{', inside it' if result.resume.partial else ''}; ledger "
                          f"{ledger_path})", highlight=False)
        raise click.ClickException(result.fault.message)
    ledger.check()
    st = result.status
    console.print(f"done: {ledger.last_acknowledged - ledger.first + 1} lines acknowledged, machine "
                  f"{st.state} at X{st.wpos[0]:.3f} Y{st.wpos[1]:.3f} Z{st.wpos[2]:.3f} (work)"
                  + (f"; {len(link.garbage)} garbage lines ignored" if link.garbage else ""), highlight=False)
    sys.stdout.flush()
