"""What goes into a report: a run's digest, its summary and context, laid into the page's data.

`run_report` writes the report of one run, `compare_report` that of two runs
aligned by distance with their differences. Each run becomes a section of typed
arrays named r<k>_* in the blob and an entry of `info["runs"]`; report.js reads
the same names.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ipo.contracts import LIMIT_NAMES
from machine.report.digest import MAX_BUCKETS, ROW, Digest, digest_trace
from machine.report.envelope import Envelope, EnvelopeData
from machine.report.page import Blob, write_page

SURFACE_NODES = 300  # per side of the workpiece's height map in the page: 90 000 nodes, ~0.4 MB
LIMIT_COLOURS = ("#66bb6a", "#42a5f5", "#ffa726", "#ec407a", "#7e57c2", "#fdd835", "#9e9e9e", "#8d6e63")


def _source_lines(path: str | Path, wanted: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """The text of the executed source lines (1-based numbers), as the file has them."""
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return np.zeros(0, dtype=np.int32), []
    lines = np.unique(wanted)
    lines = lines[(lines >= 1) & (lines <= len(text))]
    return lines.astype(np.int32), [text[n - 1].rstrip() for n in lines]


def surface_grid(x_mm: np.ndarray, y_mm: np.ndarray, z_mm: np.ndarray, nodes: int = SURFACE_NODES):
    """A height map z_mm[j, i] over x_mm[i], y_mm[j] reduced to at most `nodes` per side, each node
    the lowest height of its block (a gouge or the deepest cut is never smoothed away), at the
    block's first coordinates."""
    sx, sy = max(1, -(-len(x_mm) // nodes)), max(1, -(-len(y_mm) // nodes))
    z = np.minimum.reduceat(np.minimum.reduceat(z_mm, np.arange(0, len(y_mm), sy), axis=0),
                            np.arange(0, len(x_mm), sx), axis=1)
    return x_mm[::sx], y_mm[::sy], z


def _add_envelope(blob: Blob, prefix: str, env: EnvelopeData) -> None:
    blob.add(prefix + "lo", env.lo, "f4")
    blob.add(prefix + "hi", env.hi, "f4")
    blob.add(prefix + "arg_lo", env.arg_lo, "i4")
    blob.add(prefix + "arg_hi", env.arg_hi, "i4")
    if env.counts.shape[1]:
        blob.add(prefix + "reason", env.dominant(), "u1")


def add_run(blob: Blob, k: int, digest: Digest, *, name: str, program_file: str | Path, rapid_lines,
            summary: dict | None = None, warnings=(), messages=(), machine: dict | None = None,
            surface=None) -> dict:
    """Lay one run into the blob; the returned dict is its entry in info["runs"]."""
    p = f"r{k}_"
    _add_envelope(blob, p + "env_", digest.env)
    blob.add(p + "run_first", digest.run_first_period, "i4")
    blob.add(p + "run_line", digest.run_line, "i4")
    rows = digest.path_rows
    blob.add(p + "path_period", digest.path_period, "i4")
    blob.add(p + "path_xyz", rows[:, 0:3], "f4")
    blob.add(p + "path_s", rows[:, ROW.index("s")], "f8")
    blob.add(p + "path_feed", rows[:, ROW.index("feed")], "f4")
    blob.add(p + "path_limit", rows[:, ROW.index("limit")], "u1")
    line = rows[:, ROW.index("line")].astype(np.int64)
    blob.add(p + "path_line", line, "i4")
    blob.add(p + "path_rapid", np.isin(line, np.fromiter(rapid_lines, dtype=np.int64)), "u1")
    numbers, texts = _source_lines(program_file, digest.run_line)
    blob.add(p + "text_line", numbers, "i4")
    blob.add_text(p + "text", texts)
    has_surface = surface is not None
    if has_surface:  # the virtual workpiece's height map, when the run computed one
        x, y, z = surface_grid(surface.x_mm, surface.y_mm, surface.z_mm)
        blob.add(p + "surf_x", x, "f4")
        blob.add(p + "surf_y", y, "f4")
        blob.add(p + "surf_z", z, "f4")
    meta = digest.meta
    return {"name": name, "file": str(program_file), "period_s": digest.period_s, "periods": digest.periods,
            "width": digest.env.width, "signals": list(digest.signals),
            "limits": {"v": meta.get("max_velocity_mm_s"), "a": meta.get("max_accel_mm_s2"),
                       "j": meta.get("max_jerk_mm_s3")},
            "stencil_periods": meta.get("stencil_periods", 1),
            "summary": summary or {}, "warnings": [str(w) for w in warnings], "messages": list(messages),
            "machine": machine or {}, "surface": has_surface}


def machine_info(machine_file: str | None) -> dict:
    """The machine file's name and text (the packaged default when none was given)."""
    from importlib import resources

    if machine_file is None:
        text = resources.files("ipo").joinpath("machine.toml").read_text(encoding="utf-8")
        return {"path": "(built-in default: ipo/machine.toml)", "text": text}
    return {"path": str(machine_file), "text": Path(machine_file).read_text(encoding="utf-8", errors="replace")}


def _base_info(kind: str) -> dict:
    return {"kind": kind, "limit_names": list(LIMIT_NAMES), "limit_colours": list(LIMIT_COLOURS),
            "written": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())}


def run_report(out: str | Path, digest: Digest, *, program, summary: dict, machine: dict, surface=None) -> Path:
    """The report of one run: `program` is the machine.check.CheckedProgram (warnings, rapids, file);
    `surface` the virtual workpiece's height map (x_mm, y_mm, z_mm[j, i] attributes) when the run cut one."""
    blob = Blob()
    entry = add_run(blob, 0, digest, name=Path(program.file).name, program_file=program.file,
                    rapid_lines=program.rapid_lines,
                    summary=summary, warnings=program.warnings, messages=summary.get("messages", ()),
                    machine=machine, surface=surface)
    info = dict(_base_info("run"), runs=[entry])
    return write_page(out, f"vcnc run {program.file}", info, blob)


DIFFERENCES = ("Δ feed mm/s", "path gap µm")  # the second's feed minus the first's; distance between the paths


def differences(run_a: dict, run_b: dict, *, batch: int = 1 << 16) -> EnvelopeData:
    """Envelopes over the first run's periods of how the second differs at the same distance along
    the path (the second's distance scaled to the first's length, as compare's path distance does):
    its planned feed minus the first's, and the distance from the first's path to the second's."""
    tr_a, tr_b = run_a["trace"], run_b["trace"]
    s_a, s_b = (np.cumsum(np.linalg.norm(np.diff(t["pos_mm"], axis=0, prepend=t["pos_mm"][:1]), axis=1))
                for t in (tr_a, tr_b))
    scale = s_a[-1] / s_b[-1] if s_b[-1] > 0 else 1.0
    env = Envelope(len(DIFFERENCES), max_buckets=MAX_BUCKETS)
    for i in range(0, len(tr_a), batch):
        part = slice(i, i + batch)
        feed_b = np.interp(s_a[part], s_b * scale, tr_b["feed_mm_s"])
        env.add(np.column_stack((feed_b - tr_a["feed_mm_s"][part], run_a["deviation_mm"][part] * 1e3)))
    return env.finish()


def compare_report(out: str | Path, runs: dict, files: list[str], table: list[list[str]], machine: dict) -> Path:
    """The report of `vcnc compare`: runs["a"], runs["b"] as compare's _run keeps them."""
    blob = Blob()
    entries = []
    for k, key in enumerate("ab"):
        run = runs[key]
        program = run["program"]
        digest = digest_trace(run["trace"])
        entries.append(add_run(blob, k, digest, name=Path(files[k]).name, program_file=program.file,
                               rapid_lines=program.rapid_lines,
                               summary=run["summary"], warnings=program.warnings,
                               messages=run["summary"].get("messages", ()), machine=machine))
    _add_envelope(blob, "d_env_", differences(runs["a"], runs["b"]))
    info = dict(_base_info("compare"), runs=entries, compare={"signals": list(DIFFERENCES), "table": table})
    return write_page(out, f"vcnc compare {files[0]} {files[1]}", info, blob)
