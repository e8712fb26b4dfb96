"""`vcnc serve`: a fork server that pays vcnc's start-up once and runs each client's command in a child.

Start-up is ~0.38 s of every fresh `vcnc` process (imports 0.2 s, numba's first cached kernel
~0.08 s, the others ~0.08 s more), more than the work of a short program. The server imports
the offline commands and machine.plot (matplotlib) and runs `vcnc warmup`'s programs
(machine.commands.warmup.exercise), so every kernel they use is loaded; then, per request from machine.client, it forks. The child
takes the client's cwd, environment, umask, argv and stdin/stdout/stderr descriptors, rebuilds
sys.stdin/stdout/stderr as the client's Python had them, runs the command through
machine.cli's group as `vcnc` would in-process, runs the exit handlers registered meanwhile,
flushes and exits with the command's code. The server reaps it (os.wait4) and sends the client
its wait status and CPU time.

No thread may exist in the server when it forks (a child would inherit a lock held by a thread
it does not have): warming starts none (machine.commands keeps BLAS single-threaded, numba's
parallel layer is never used), and `serve` checks it before listening.

Safety: the socket's directory is 0700 and the user's (machine.client.check_owned), the socket
0600, and a peer of another uid is refused. A client that goes away (killed, its terminal
closed) takes its child with it: its connection reaching end of stream makes the server
SIGKILL the child. Signals the client receives (SIGINT, SIGTERM, SIGHUP; Ctrl-Z as SIGSTOP and
SIGCONT) are forwarded; the child has Python's default handlers (those the client ignores
ignored), so Ctrl-C ends a command as it would in-process.
"""
from __future__ import annotations

import atexit
import gc
import io
import os
import selectors
import signal
import socket
import stat
import struct
import sys
import time
import traceback

from machine import client

# what the offline commands import, up front or when they run (machine.workpiece.measure: scipy.signal,
# 0.43 s of `vcnc surface-report`'s 0.55)
COMMAND_MODULES = ("machine.commands.parse", "machine.commands.interp", "machine.commands.run",
                   "machine.commands.compare", "machine.commands.fit", "machine.commands.plot",
                   "machine.commands.surface", "machine.commands.surface_report", "machine.commands.toolpath",
                   "machine.plot", "machine.report.build", "machine.workpiece.cli_run", "machine.workpiece.measure",
                   "machine.workpiece.figures", "machine.workpiece.surface_file", "machine.workpiece.plot",
                   "ipo.surface.iges", "ipo.surface.section_fit", "ipo.surface.sections", "ipo.surface.skinning",
                   "ipo.surface.toolpath", "rich.console", "rich.table", "rich.live", "rich.progress")
FORWARDED_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGSTOP, signal.SIGCONT)
REQUEST_TIMEOUT_S = 5.0   # a client sends its request at once; a stalled one must not block the server


class ServerError(Exception):
    """The server cannot start (its reason is the message)."""


def warm(log) -> None:
    """Import the offline commands and matplotlib, and load every kernel `vcnc warmup` exercises."""
    import importlib

    from machine.commands.warmup import exercise

    t0 = time.perf_counter()
    for name in COMMAND_MODULES:
        importlib.import_module(name)
    exercise(None)
    gc.collect()
    gc.freeze()   # the children's collections need not walk (and copy on write) the server's objects
    log(f"warmed in {time.perf_counter() - t0:.1f} s")


def check_free(path: str) -> None:
    """Refuse if a server already answers at path, or its directory is not this user's own
    (created 0700 if missing); a socket left by a killed server is removed."""
    folder = os.path.dirname(path)
    os.makedirs(folder, mode=0o700, exist_ok=True)
    client.check_owned(folder, stat.S_IFDIR)
    if os.path.lexists(path):
        client.check_owned(path, stat.S_IFSOCK)
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            probe.connect(path)
            raise ServerError(f"a vcnc server already listens at {path} (vcnc serve --status)")
        except (ConnectionRefusedError, FileNotFoundError):
            os.unlink(path)
        finally:
            probe.close()


def listen(path: str) -> socket.socket:
    """The listening socket at path (0600)."""
    check_free(path)
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    old = os.umask(0o177)
    try:
        listener.bind(path)
    finally:
        os.umask(old)
    listener.listen(64)
    return listener


class Server:
    """The accept loop: requests in, children forked and reaped, statuses out."""

    def __init__(self, listener: socket.socket, key: dict, log):
        self.listener = listener
        self.key = key
        self.log = log
        self.started = time.time()
        self.children: dict[int, socket.socket] = {}   # child pid -> its client's connection
        self.requests = 0
        self.children_cpu_s = 0.0
        self.told_stale = False
        self.stopping = False
        self.selector = selectors.DefaultSelector()
        self.wake_r, self.wake_w = os.pipe()
        os.set_blocking(self.wake_w, False)

    def serve(self) -> None:
        signal.set_wakeup_fd(self.wake_w)
        for signum in (signal.SIGCHLD, signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            if signal.getsignal(signum) != signal.SIG_IGN:   # `nohup vcnc serve` outlives its terminal
                signal.signal(signum, lambda *_: None)   # the wake-up byte says which
        self.selector.register(self.listener, selectors.EVENT_READ, self._accept)
        self.selector.register(self.wake_r, selectors.EVENT_READ, self._signalled)
        while not (self.stopping and not self.children):
            for key, _ in self.selector.select():
                key.data(key.fileobj)

    def _signalled(self, _fd) -> None:
        for signum in os.read(self.wake_r, 512):
            if signum == signal.SIGCHLD:
                self._reap()
            else:
                self.stop(f"signal {signal.Signals(signum).name}")

    def stop(self, why: str) -> None:
        if not self.stopping:
            self.log(f"stopping ({why}); {len(self.children)} command(s) still running")
            self.stopping = True
            self.selector.unregister(self.listener)
            os.unlink(self.listener.getsockname())
            self.listener.close()

    def _accept(self, _listener) -> None:
        conn, _ = self.listener.accept()
        conn.settimeout(REQUEST_TIMEOUT_S)
        fds = []
        try:
            creds = conn.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i"))
            if struct.unpack("3i", creds)[1] != os.getuid():
                return
            request, fds = client.receive(conn, 3)
            if request is None:
                return
            op = request.get("op")
            if op == "status":   # with the asker's key: whether this server runs its code
                client.send(conn, dict(self.status(), differs=None if request.get("key", self.key) == self.key
                                       else _difference(self.key, request["key"])))
            elif op == "stop":
                client.send(conn, self.status())
                self.stop("vcnc serve --stop")
            elif op == "run" and len(fds) == 3:
                if request["key"] != self.key:
                    client.send(conn, {"stale": self._stale_text(request["key"])})
                else:
                    self._fork(conn, request, fds)
                    conn = None   # now the child's: closed when it is reaped
        except (OSError, ValueError) as err:
            self.log(f"a request failed: {err}")
        finally:
            for fd in fds:
                os.close(fd)
            if conn is not None:
                conn.close()

    def _stale_text(self, theirs: dict) -> str:
        if self.told_stale:
            return ""
        self.told_stale = True
        return (f"the vcnc server (pid {os.getpid()}) runs other code or settings than this vcnc "
                f"({_difference(self.key, theirs)}); restart `vcnc serve`")

    def _fork(self, conn: socket.socket, request: dict, fds: list[int]) -> None:
        pid = os.fork()
        if pid == 0:
            try:
                self._close_in_child(conn)
                run_child(request, fds)
            except BaseException:   # noqa: BLE001  (setting up the client's process failed: say why)
                traceback.print_exc()
                _flush()
            finally:
                os._exit(70)   # never unwind into the server's frames
        self.requests += 1
        conn.settimeout(None)
        self.children[pid] = conn
        self.selector.register(conn, selectors.EVENT_READ, self._from_client)
        client.send(conn, {"pid": pid})

    def _close_in_child(self, conn: socket.socket) -> None:
        signal.set_wakeup_fd(-1)
        self.selector.close()
        for fd in (self.wake_r, self.wake_w):
            os.close(fd)
        for other in list(self.children.values()) + [conn]:
            other.close()
        self.listener.close()

    def _from_client(self, conn: socket.socket) -> None:
        pid = next(p for p, c in self.children.items() if c is conn)
        try:
            message, _ = client.receive(conn)
        except (OSError, ValueError):
            message = None
        if message is None:   # the client is gone: so is its command
            self.selector.unregister(conn)
            _kill(pid, signal.SIGKILL)
        elif message.get("signal") in FORWARDED_SIGNALS:
            _kill(pid, message["signal"])

    def _reap(self) -> None:
        while self.children:
            pid, status, usage = os.wait4(-1, os.WNOHANG)
            if pid == 0:
                return
            conn = self.children.pop(pid, None)
            cpu_s = usage.ru_utime + usage.ru_stime
            self.children_cpu_s += cpu_s
            if conn is None:
                continue
            if conn.fileno() in self.selector.get_map():
                self.selector.unregister(conn)
            try:
                client.send(conn, {"status": status, "cpu_s": cpu_s})
            except OSError:
                pass
            conn.close()

    def status(self) -> dict:
        return {"pid": os.getpid(), "socket": self.listener.getsockname() if not self.stopping else None,
                "started": self.started, "requests": self.requests, "running": sorted(self.children),
                "children_cpu_s": self.children_cpu_s, "server_cpu_s": time.process_time(),
                "stopping": self.stopping}


def _difference(mine: dict, theirs: dict) -> str:
    """The first thing that differs between two code keys (machine.client.code_key), in words."""
    for name in ("python", "root", "libraries"):
        if theirs.get(name) != mine[name]:
            return f"{name}: {mine[name]} in the server, {theirs.get(name)} here"
    env_mine, env_theirs = mine["env"], theirs.get("env", {})
    names = sorted(k for k in env_mine.keys() | env_theirs.keys() if env_mine.get(k) != env_theirs.get(k))
    if names:
        return "environment: " + ", ".join(f"{k} {env_mine.get(k)!r} in the server, {env_theirs.get(k)!r} here"
                                           for k in names)
    files_mine = {f[0]: f for f in mine["files"]}
    changed = [f[0] for f in theirs.get("files", []) if files_mine.pop(f[0], None) != f] + sorted(files_mine)
    return f"{changed[0]} changed since it started" if changed else "its key differs"


def _kill(pid: int, signum: int) -> None:
    try:
        os.kill(pid, signum)
    except ProcessLookupError:   # exited, not yet reaped
        pass


def run_child(request: dict, fds: list[int]) -> None:
    """In the forked child: become the client's process for its command, run it, exit."""
    # A session of its own, without a controlling terminal: the server's may be the user's terminal
    # (`vcnc serve &`), whose job control would stop the child (SIGTTIN, SIGTTOU) or fail it (EIO)
    # when it reads the client's terminal or sets it up for keys (an M0 prompt, `run --realtime`),
    # and whose Ctrl-C would reach it.
    os.setsid()
    for signum in (signal.SIGCHLD, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)   # Python's own, as in-process
    for signum in request["ignored_signals"]:   # as Python leaves them when it starts
        signal.signal(signum, signal.SIG_IGN)
    for target, fd in enumerate(fds):
        os.dup2(fd, target)
        os.close(fd)
    sys.stdin, sys.stdout, sys.stderr = (_text_stream(fd, spec) for fd, spec in enumerate(request["stdio"]))
    os.umask(request["umask"])
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    for name, value in client.THREAD_DEFAULTS.items():
        os.environ.setdefault(name, value)   # as machine.commands' import does in-process
    sys.argv = request["argv"]
    atexit._clear()   # the server's own handlers are not the command's
    from machine.cli import main

    code = 0
    try:
        main(args=request["argv"][1:], prog_name=request["prog_name"])
    except SystemExit as done:
        code = done.code
        if code is None:
            code = 0
        elif not isinstance(code, int):   # sys.exit("text"): printed, exit 1, as Python does
            print(code, file=sys.stderr)
            code = 1
    except KeyboardInterrupt:
        traceback.print_exc()
        _flush()
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGINT)
    except BaseException as err:   # noqa: BLE001  (--debug: the traceback, as Python prints it)
        sys.excepthook(type(err), err, err.__traceback__)
        code = 1
    atexit._run_exitfuncs()
    _flush()
    os._exit(code & 0xFF)


def _text_stream(fd: int, spec: dict) -> io.TextIOWrapper:
    """sys.stdin/stdout/stderr over fd as Python builds them (newline "\\n", no translation),
    with the client's encoding, errors and buffering."""
    raw = open(fd, "rb" if fd == 0 else "wb", closefd=False)
    return io.TextIOWrapper(raw, encoding=spec["encoding"], errors=spec["errors"], newline="\n",
                            line_buffering=spec["line_buffering"], write_through=spec["write_through"])


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):   # a closed pipe: in-process the output would be lost too
            pass


def threads() -> int:
    return len(os.listdir("/proc/self/task")) if os.path.isdir("/proc/self/task") else 1
