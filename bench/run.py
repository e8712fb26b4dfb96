"""Benchmark of `vcnc run`: whole processes, fresh and warm, and where the time goes.

    python bench/run.py [--quick] [--no-fresh] [--no-phases]

Programs: g1_stellabee1, g1_lhchips4, g6_farfalla (../shared/corpus/linuxcnc, the default
machine), programs/finish_nurbs.nc (programs/finish_machine.toml: the roughness limiter on),
a generated 2,000,000-line G01 raster (GENERATED_BLOCKS; the default machine) and
programs/demo.nc (programs/machine.toml).

1. Whole processes: `python -m machine.cli run FILE --json` in a child reaped with os.wait4:
   wall time, CPU time (user + system: the figure a shared machine's load does not move),
   Python's bytecode cache on as in a user's install (`with_bytecode`),
   realtime factor = simulated time / each, and peak RSS. "warm": numba's cache holds every
   kernel (a first run filled it); "fresh": NUMBA_CACHE_DIR is an empty directory, so the
   process compiles every kernel it calls. Demo's first run as the README's first command
   makes it: a fresh cache, `vcnc warmup`, then `vcnc run` (bar: <= 10 s of wall time).
2. Where the time goes: each program run in this process (warm kernels) with a trace sink
   writing the rows as --trace does, its CPU time charged to the phase running at each
   moment (exclusive, like a profiler's self time, but by phase): parse (ipr), check (the
   rest of the whole-program check: travel, NURBS the planner cannot walk), plan (pieces,
   samples, caps, look-ahead: the planner's own time), interpolate (the period grid, the
   points of every period, NURBS stepping, BLU quantising: the output side), drive
   (integration, limits, measurements), trace (the sink), other (the run loop).
1b. The same runs through `vcnc serve` (machine.server): a server started by the bench (its own
   XDG_RUNTIME_DIR), each run a whole `python -m machine.client run FILE --json` process (the
   `vcnc` entry point) whose command the server's forked child runs: wall time of the client
   (the user's wait), CPU time = the client's (os.wait4) + the child's (os.wait4 in the server)
   + the server's own in that time (the fork), each from the server's status before and after.
3. `vcnc interp` on a cubic NURBS with 30 control points (bench/interp.py's throughput
   curve), recursive n1 = 2, D = its length / 2,000,000: the periods per second it reports
   (its stepping's wall time) and periods per wall second of the whole process, warm (a
   short run first fills numba's cache if it lacks the steppers), then through `vcnc serve`.

Bars (issue 22): >= 1000x real time by CPU time on g1_stellabee1 and g1_lhchips4, >= 200x on
g6_farfalla; the 2 M-line program within 600 MB; demo's first run <= 10 s; vcnc interp
>= 5 M periods per second of wall time; each judged on the cold process and through the server.

--quick: leaves out stellabee1 and the 2 M-line program, and the fresh-cache rows but demo's.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
CORPUS = ROOT.parent / "shared" / "corpus" / "linuxcnc"
GENERATED_BLOCKS = 2_000_000
PHASES = ("parse", "check", "plan", "interpolate", "drive", "trace", "other")


def generated_raster(path: Path, n_blocks: int = GENERATED_BLOCKS) -> Path:
    """n G01 blocks of a finishing raster like CAM output: passes along X over a 100 x 100 mm
    patch, 0.5 mm apart in Y, 0.2 mm steps, Z following a gentle bump, 3 decimals, F1500."""
    per_pass = 500
    k = np.arange(n_blocks)
    j, i = divmod(k, per_pass)
    x = np.where(j % 2 == 0, i, per_pass - 1 - i) * 0.2
    y = (j % 200) * 0.5
    z = 2.0 * np.exp(-((x - 50.0) ** 2 + (y - 50.0) ** 2) / 800.0)
    with path.open("w") as f:
        f.write("G21 G17 G90 G94 G64 P0.01\nG0 X0 Y0 Z5\nG1 Z0 F1500\n")
        f.writelines(f"X{a:.3f} Y{b:.3f} Z{c:.3f}\n" for a, b, c in zip(x, y, z))
        f.write("G0 Z5\nM2\n")
    return path


def nurbs_program(path: Path) -> tuple[Path, float]:
    """bench/interp.py's throughput curve as one G06.2 group; returns it and its length (mm)."""
    sys.path.insert(0, str(ROOT / "bench"))
    from interp import throughput_curve  # noqa: E402 (bench/interp.py)

    from ipo.nurbs import kernel as nk
    from ipr import parse_file

    e = throughput_curve()
    pts, w, knots, p = e.points, e.weights, e.knots, e.degree
    lines = ["G21 G90 G17", f"G0 X{pts[0, 0]:.6f} Y{pts[0, 1]:.6f} Z{pts[0, 2]:.6f}"]
    for i in range(len(pts)):
        head = f"G06.2 P{p + 1} " if i == 0 else ""
        lines.append(f"{head}K{knots[i]:.10f} X{pts[i, 0]:.6f} Y{pts[i, 1]:.6f} Z{pts[i, 2]:.6f} R{w[i]:.6f}"
                     + (" F1000" if i == 0 else ""))
    lines += [f"K{k:.10f}" for k in knots[len(pts):]] + ["M2"]
    path.write_text("\n".join(lines) + "\n")
    written = next(x for x in parse_file(path).entities if type(x).__name__ == "Nurbs")
    return path, float(nk.arc_length(written.degree, written.knots, written.weights, written.points))


def process(args: list[str], env: dict | None = None, module: str = "machine.cli") -> dict:
    """One `python -m MODULE ARGS` process: its stdout, wall and CPU seconds, peak RSS."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        pid = os.fork()
        if pid == 0:
            os.chdir(ROOT)
            os.dup2(out.fileno(), 1)
            os.dup2(err.fileno(), 2)
            os.execve(sys.executable, [sys.executable, "-m", module, *args], with_bytecode(env or os.environ))
        _, status, usage = os.wait4(pid, 0)
        wall = time.perf_counter() - t0
        out.seek(0)
        err.seek(0)
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"vcnc {' '.join(args)} failed: {err.read().decode()[-800:]}")
        return {"stdout": out.read().decode(), "wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime,
                "rss_mb": usage.ru_maxrss / 1024}


def with_bytecode(env) -> dict:
    """`env` with Python's bytecode cache on, as in a user's install: PYTHONDONTWRITEBYTECODE
    (set in some sandboxes) would compile each of vcnc's modules from source in every
    process, ~0.15 s of CPU that no user pays."""
    return {k: v for k, v in env.items() if k != "PYTHONDONTWRITEBYTECODE"}


def fresh_env(cache_dir: str) -> dict:
    return dict(os.environ, NUMBA_CACHE_DIR=cache_dir)


def run_row(name: str, path: Path, machine: Path | None, env: dict | None) -> dict:
    r = process(["run", str(path), "--json"] + (["--machine", str(machine)] if machine else []), env)
    r["summary"] = json.loads(r["stdout"].strip().splitlines()[-1])
    sim = r["summary"]["cycle_time_s"]
    print(f"{name:28s} {r['summary']['periods']:10d} {sim:9.1f} {r['wall_s']:8.2f} {sim / r['wall_s']:9.1f} "
          f"{r['cpu_s']:8.2f} {sim / r['cpu_s']:9.1f} {r['rss_mb']:8.1f}", flush=True)
    return r


class Server:
    """A `vcnc serve` of this checkout for the bench alone (its socket in a private runtime
    directory), and runs through it."""

    def __init__(self, runtime: Path):
        runtime.mkdir(mode=0o700)
        self.env = with_bytecode(dict(os.environ, XDG_RUNTIME_DIR=str(runtime)))
        self.env.pop("VCNC_NO_SERVER", None)
        self.proc = subprocess.Popen([sys.executable, "-m", "machine.cli", "serve"], cwd=ROOT, env=self.env,
                                     stdout=subprocess.PIPE, text=True)
        for line in self.proc.stdout:
            if " ready at " in line:
                self.socket = line.split(" ready at ")[1].split()[0]
                return
        raise SystemExit(f"vcnc serve did not start (exit {self.proc.wait()})")

    def status(self) -> dict:
        from machine import client

        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
            sock.connect(self.socket)
            client.send(sock, {"op": "status"})
            return client.receive(sock)[0]

    def process(self, args: list[str]) -> dict:
        """process() of the `vcnc` entry point, its cpu_s with the server's and its child's."""
        before = self.status()
        r = process(args, self.env, module="machine.client")
        after = self.status()
        if after["requests"] != before["requests"] + 1:
            raise SystemExit(f"vcnc {' '.join(args)} did not go through the server")
        r["cpu_s"] += sum(after[k] - before[k] for k in ("children_cpu_s", "server_cpu_s"))
        return r

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGTERM)
        self.proc.communicate()


def served_row(name: str, path: Path, machine: Path | None, server: Server) -> dict:
    r = server.process(["run", str(path), "--json"] + (["--machine", str(machine)] if machine else []))
    r["summary"] = json.loads(r["stdout"].strip().splitlines()[-1])
    sim = r["summary"]["cycle_time_s"]
    print(f"{name:28s} {r['summary']['periods']:10d} {sim:9.1f} {r['wall_s']:8.2f} {sim / r['wall_s']:9.1f} "
          f"{r['cpu_s']:8.2f} {sim / r['cpu_s']:9.1f}", flush=True)
    return r


# ---- phases -------------------------------------------------------------------------
class PhaseClock:
    """CPU time charged to the phase on top of a stack (exclusive time per phase)."""

    def __init__(self):
        self.seconds: dict[str, float] = defaultdict(float)
        self._stack = ["other"]
        self._t = time.process_time()

    def push(self, phase: str) -> None:
        t = time.process_time()
        self.seconds[self._stack[-1]] += t - self._t
        self._t = t
        self._stack.append(phase)

    def pop(self) -> None:
        t = time.process_time()
        self.seconds[self._stack.pop()] += t - self._t
        self._t = t

    def function(self, phase: str, fn):
        def timed(*a, **k):
            self.push(phase)
            try:
                return fn(*a, **k)
            finally:
                self.pop()
        return timed

    def generator(self, phase: str, fn):
        """A generator function whose every resumption is charged to phase (not the time
        its consumer spends between items); its return value passes through."""
        clock = self

        def timed(*a, **k):
            gen = fn(*a, **k)
            sent = None
            try:
                while True:
                    clock.push(phase)
                    try:
                        item = gen.send(sent)
                    except StopIteration as stop:
                        return stop.value
                    finally:
                        clock.pop()
                    sent = yield item
            finally:
                gen.close()
        return timed


def phase_split(path: Path, machine: Path | None, trace_dir: Path) -> tuple[dict, float]:
    """CPU seconds per phase of one in-process run, and its simulated time."""
    import machine.controller as mc
    from ipo.config import default_config, load_config
    from ipo.feed import emission, planner
    from ipr.interpretation import Interpretation
    from machine import drive
    from machine.trace import NpzTraceWriter

    clock = PhaseClock()
    patches = [(Interpretation, "__iter__", clock.generator("parse", Interpretation.__iter__)),
               (mc.Controller, "check", clock.function("check", mc.Controller.check)),
               (planner.FeedPlanner, "run", clock.generator("plan", planner.FeedPlanner.run)),
               (emission.PeriodOutput, "emit", clock.generator("interpolate", emission.PeriodOutput.emit)),
               (drive.Drive, "receive", clock.function("drive", drive.Drive.receive)),
               (NpzTraceWriter, "write", clock.function("trace", NpzTraceWriter.write))]
    saved = [(owner, name, getattr(owner, name)) for owner, name, _ in patches]
    try:
        for owner, name, fn in patches:
            setattr(owner, name, fn)
        config = load_config(machine) if machine else default_config()
        controller = mc.Controller(config)
        clock.seconds.clear()
        clock.push("other")
        program = controller.check(path)
        writer = NpzTraceWriter(trace_dir / "trace.npz", controller.limits.meta(), servo=False)
        controller.sinks = [writer]
        result = controller.run(program)
        clock.pop()
        clock.push("trace")
        writer.close()
        clock.pop()
    finally:
        for owner, name, fn in saved:
            setattr(owner, name, fn)
    return dict(clock.seconds), result.cycle_time_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="leave out stellabee1, the 2 M-line program, "
                                                         "and the fresh rows but demo's")
    ap.add_argument("--no-fresh", action="store_true", help="leave out every fresh-cache row")
    ap.add_argument("--no-phases", action="store_true", help="leave out the phase split")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="vcnc-bench-run-"))
    programs = [("g1_stellabee1", CORPUS / "g1_stellabee1.ngc", None),
                ("g1_lhchips4", CORPUS / "g1_lhchips4.ngc", None),
                ("g6_farfalla", CORPUS / "g6_farfalla.ngc", None),
                ("finish_nurbs", ROOT / "programs" / "finish_nurbs.nc", ROOT / "programs" / "finish_machine.toml"),
                (f"generated {GENERATED_BLOCKS // 1_000_000} M-line G01", None, None),
                ("demo", ROOT / "programs" / "demo.nc", ROOT / "programs" / "machine.toml")]
    if args.quick:
        programs = [p for p in programs if p[0] not in ("g1_stellabee1",) and p[1] is not None]
    rows = []
    for name, path, machine in programs:
        if path is None:
            t0 = time.perf_counter()
            path = generated_raster(tmp / "generated.ngc")
            print(f"(generated {GENERATED_BLOCKS:,} G01 blocks in {time.perf_counter() - t0:.1f} s: {path})")
        if not path.exists():
            print(f"skipped (not found): {path}")
            continue
        rows.append((name, path, machine))

    process(["run", str(ROOT / "programs" / "demo.nc"), "--json"])  # the default cache holds every kernel
    server = Server(tmp / "runtime")
    try:
        measure(rows, args, tmp, server)
    finally:
        server.stop()


def measure(rows: list, args, tmp: Path, server: Server) -> None:
    head = (f"{'program':28s} {'periods':>10s} {'sim s':>9s} {'wall s':>8s} {'x (wall)':>9s} {'cpu s':>8s} "
            f"{'x (cpu)':>9s} {'peak MB':>8s}")
    print("\n1. whole `vcnc run --json` processes, warm numba cache\n" + head)
    warm = {name: run_row(name, path, machine, None) for name, path, machine in rows}
    print("\n1b. the same through `vcnc serve` (the client's wall time; CPU: client + the server's child + "
          "the server)\n" + head.replace(f" {'peak MB':>8s}", ""))
    served = {name: served_row(name, path, machine, server) for name, path, machine in rows}
    if not args.no_fresh:
        print("\n   the same with a fresh numba cache (every kernel compiled in the process)\n" + head)
        for name, path, machine in rows:
            if args.quick and name != "demo":
                continue
            with tempfile.TemporaryDirectory() as cache:
                run_row(name, path, machine, fresh_env(cache))
        with tempfile.TemporaryDirectory() as cache:
            w = process(["warmup"], fresh_env(cache))
            d = process(["run", str(ROOT / "programs" / "demo.nc"), "--json"], fresh_env(cache))
        print(f"\n   README's first command on a fresh cache: vcnc warmup {w['wall_s']:.1f} s wall "
              f"({w['cpu_s']:.1f} s CPU), then vcnc run programs/demo.nc {d['wall_s']:.2f} s wall "
              f"({d['cpu_s']:.2f} s CPU) -> bar <= 10 s {'met' if d['wall_s'] <= 10 else 'NOT met'}")

    if not args.no_phases:
        print("\n2. where the time goes: CPU seconds per phase, in this process (warm kernels, a trace written)")
        print(f"{'program':28s} " + " ".join(f"{p:>11s}" for p in PHASES) + f" {'total':>8s} {'x (cpu)':>8s}")
        for name, path, machine in rows:
            split, sim = phase_split(path, machine, tmp)
            total = sum(split.values())
            print(f"{name:28s} " + " ".join(f"{split.get(p, 0.0):11.3f}" for p in PHASES)
                  + f" {total:8.2f} {sim / total:8.0f}", flush=True)

    print("\n3. vcnc interp, 30-point cubic NURBS, recursive n1 = 2, 2,000,000 periods")
    prog, length = nurbs_program(tmp / "curve30.nc")
    process(["interp", str(prog), "--step-um", f"{length / 1e3 * 1e3:.9g}", "--json"])  # warm, as section 1's rows
    interp = ["interp", str(prog), "--step-um", f"{length / 2e6 * 1e3:.9g}", "--json"]
    for how, r in (("cold", process(interp)), ("through vcnc serve", server.process(interp))):
        s = json.loads(r["stdout"].strip().splitlines()[-1])
        print(f"   {how}: {s['steps']:,} periods: {s['steps_per_s'] / 1e6:.2f} M/s as reported (stepping wall time); "
              f"{s['steps'] / r['wall_s'] / 1e6:.2f} M/s of the whole process's wall time ({r['wall_s']:.2f} s, "
              f"{r['cpu_s']:.2f} s CPU)\n   bar >= 5 M/s: as reported {'met' if s['steps_per_s'] >= 5e6 else 'NOT met'}; "
              f"by the whole process's wall time {'met' if s['steps'] / r['wall_s'] >= 5e6 else 'NOT met'}")

    print("\nbars (CPU time: the whole process; through the server: client + child + server)")
    for name, bar in (("g1_stellabee1", 1000), ("g1_lhchips4", 1000), ("g6_farfalla", 200)):
        if name in warm:
            judged = []
            for how, r in (("through the server", served[name]), ("cold", warm[name])):
                x = r["summary"]["cycle_time_s"] / r["cpu_s"]
                judged.append(f"{x:.0f}x {how} ({'met' if x >= bar else 'NOT met'}; "
                              f"{r['summary']['cycle_time_s'] / r['wall_s']:.0f}x by wall time)")
            print(f"   {name}: bar >= {bar}x real time by CPU time: " + ", ".join(judged))
    big = next((r for n, r in warm.items() if n.startswith("generated")), None)
    if big is not None:
        print(f"   2 M-line program: peak RSS {big['rss_mb']:.0f} MB (bar <= 600 MB: "
              f"{'met' if big['rss_mb'] <= 600 else 'NOT met'})")


if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    main()
