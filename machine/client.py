"""The `vcnc` entry point: hand the command to a running `vcnc serve` of the same code, else run it here.

A fresh `vcnc` process spends ~0.38 s before its first period (Python, numpy, numba, loading
the cached kernels), more than a short program's whole run. `vcnc serve` (machine.server) pays
that once; this module, imported before anything heavy (stdlib only: with the machine package's
import ~10 ms of CPU over Python's own start), passes the command to it: argv, cwd, environment, umask, and the stdin/stdout/stderr
file descriptors themselves (SCM_RIGHTS), so the forked child writes to the user's terminal or
pipes as this process would. It then waits for the child's exit status and exits with it;
SIGINT, SIGTERM and SIGHUP are forwarded to the child (those ignored here are ignored there),
Ctrl-Z stops it with this process and `fg`/`bg` continue it; if this process dies, the server
kills the child (the connection closing is the signal).

The command runs here, exactly as without a server, when:
- VCNC_NO_SERVER is set (to anything but "" or "0");
- the current directory holds a `matplotlibrc` (the server's matplotlib read its own directory's);
- it is not an offline command (FORWARDED): `stream` and `grbl` drive a board and always run in
  the process the user started, which the user can Ctrl-C; `serve`, `warmup`, help and version too;
- no server of this install listens (its socket: `socket_path()`);
- the socket or its directory is not the user's own (said on stderr);
- the server runs other code or settings: its key (`code_key()`) differs from this process's
  (the server says so on stderr once, to the first client that meets it).

Wire: each message is a 4-byte big-endian length and a JSON object; the request carries the
three descriptors. Replies: {"stale": text}, or {"pid": child}, then {"status": wait status,
"cpu_s": the child's CPU seconds (os.wait4)}.
"""
from __future__ import annotations

import os
import stat
import struct
import sys
import zlib
from pathlib import Path

from ipo.kernel_cache import package_files   # (loaded with the machine package already)

# socket, json, array and signal are imported where used: a command run in this process (no
# server) does not pay for them (~3.5 ms)

FORWARDED = frozenset({"parse", "interp", "run", "plot", "fit", "compare", "surface", "surface-report",
                       "toolpath"})
# Read once, when Python starts or numpy, OpenBLAS, numba, matplotlib or scipy load, i.e. in the server:
# a client whose values differ would get the server's (the locale: open()'s default encoding).
# The BLAS thread counts are 1 unless set, as machine.commands sets them before numpy loads (not
# imported from there: machine.commands is among the kernels' sources, ipo/kernel_cache.py, and an
# edit of this module would then recompile every kernel).
THREAD_DEFAULTS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
_ENV_PREFIXES = ("NUMBA_", "OPENBLAS_", "OMP_", "MKL_", "MPL", "SCIPY_")
_ENV_NAMES = ("PYTHONPATH", "PYTHONUTF8", "LANG", "LC_ALL", "LC_CTYPE", "TZ", "MATPLOTLIBRC", "HOME",
              "XDG_CONFIG_HOME", "XDG_CACHE_HOME")
_LIBRARIES = ("numpy", "numba", "llvmlite")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HEADER = struct.Struct("!I")
MAX_MESSAGE = 1 << 24


class Refused(Exception):
    """A socket or directory this user must not trust (its reason is the message)."""


def socket_dir() -> str:
    """$XDG_RUNTIME_DIR/vcnc, else /tmp/vcnc-UID: a 0700 directory of this user's."""
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    return os.path.join(runtime, "vcnc") if runtime else f"/tmp/vcnc-{os.getuid()}"


def socket_path() -> str:
    """One socket per install (this checkout with this Python environment), so servers of
    several checkouts or venvs can run side by side."""
    install = f"{os.path.realpath(sys.prefix)}\0{ROOT}".encode()
    return os.path.join(socket_dir(), f"{zlib.crc32(install):08x}.sock")


def check_owned(path: str, kind: int) -> None:
    """Raise Refused unless path is this user's, of kind (stat.S_IFDIR or S_IFSOCK), and a
    directory lets no one else in."""
    st = os.lstat(path)
    if stat.S_IFMT(st.st_mode) != kind:
        raise Refused(f"{path} is not a {'directory' if kind == stat.S_IFDIR else 'socket'}")
    if st.st_uid != os.getuid():
        raise Refused(f"{path} belongs to uid {st.st_uid}, not to this user ({os.getuid()})")
    if kind == stat.S_IFDIR and st.st_mode & 0o077:
        raise Refused(f"{path} is open to other users (mode {stat.S_IMODE(st.st_mode):04o}, needs 0700)")


def code_key() -> dict:
    """What a server must share with its client: the interpreter, every file of vcnc's packages
    (path, mtime, size: an edit or a checkout changes it), numpy/numba/llvmlite's installed
    files (an upgrade rewrites them), and the environment they read when they load."""
    from importlib.util import find_spec

    files = []
    for path in package_files(Path(ROOT), suffix=""):
        st = os.stat(path)
        files.append([os.path.relpath(path, ROOT), st.st_mtime_ns, st.st_size])
    libraries = []
    for name in _LIBRARIES:
        origin = find_spec(name).origin
        st = os.stat(origin)
        libraries.append([origin, st.st_mtime_ns, st.st_size])
    env = {k: v for k, v in os.environ.items() if k.startswith(_ENV_PREFIXES) or k in _ENV_NAMES}
    for name, value in THREAD_DEFAULTS.items():
        env.setdefault(name, value)
    return {"python": [os.path.realpath(sys.executable), sys.prefix, sys.version], "root": ROOT,
            "files": files, "libraries": libraries, "env": env}


def send(sock, message: dict, fds: tuple[int, ...] = ()) -> None:
    import array
    import json
    import socket

    data = json.dumps(message).encode()
    data = HEADER.pack(len(data)) + data
    if fds:
        sent = sock.sendmsg([data], [(socket.SOL_SOCKET, socket.SCM_RIGHTS, array.array("i", fds))])
        data = data[sent:]
    if data:   # (an empty send to a server that has answered and closed would fail)
        sock.sendall(data)


def receive(sock, n_fds: int = 0) -> tuple[dict | None, list[int]]:
    """The next message and the descriptors that came with it; (None, []) at end of stream."""
    import array
    import json
    import socket

    fds = array.array("i")
    if n_fds:
        data, ancillary, _, _ = sock.recvmsg(HEADER.size, socket.CMSG_SPACE(n_fds * fds.itemsize))
        for level, kind, payload in ancillary:
            if level == socket.SOL_SOCKET and kind == socket.SCM_RIGHTS:
                fds.frombytes(payload[:len(payload) - len(payload) % fds.itemsize])
    else:
        data = sock.recv(HEADER.size)
    data = _read_more(sock, data, HEADER.size)
    if data is None:
        return None, list(fds)
    (size,) = HEADER.unpack(data)
    if size > MAX_MESSAGE:
        raise ValueError(f"message of {size} bytes from the vcnc server's socket (at most {MAX_MESSAGE})")
    body = _read_more(sock, b"", size)
    return (None if body is None else json.loads(body)), list(fds)


def _read_more(sock, data: bytes, size: int) -> bytes | None:
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        if not chunk:
            return None
        data += chunk
    return data


def command_name(args: list[str]) -> str | None:
    """The subcommand of a `vcnc` argument list (after the group's own options), or None."""
    for arg in args:
        if arg == "--debug":
            continue
        return None if arg.startswith("-") else arg
    return None


def program_name() -> str:
    """click's name for this program in usage lines (click.utils._detect_program_name's rule):
    the script's name, or `python -m MODULE`; the server's child has another __main__."""
    package = getattr(sys.modules["__main__"], "__package__", None)
    name = os.path.splitext(os.path.basename(sys.argv[0]))[0]
    if not package:
        return os.path.basename(sys.argv[0])
    return f"python -m {package if name == '__main__' else f'{package}.{name}'}"


def _stdio() -> list[dict] | None:
    """How this process's stdin/stdout/stderr are set up, for the child to rebuild them."""
    streams = []
    for fd, stream in enumerate((sys.stdin, sys.stdout, sys.stderr)):
        if stream is None or not hasattr(stream, "encoding") or stream.fileno() != fd:
            return None
        streams.append({"encoding": stream.encoding, "errors": stream.errors,
                        "line_buffering": stream.line_buffering, "write_through": stream.write_through})
    return streams


def run_served(args: list[str]) -> int | None:
    """The exit code of the command run by a server, or None to run it in this process."""
    path = socket_path()
    if not os.path.exists(path):
        return None
    try:
        check_owned(os.path.dirname(path), stat.S_IFDIR)
        check_owned(path, stat.S_IFSOCK)
    except (Refused, OSError) as err:
        print(f"vcnc: not using the server's socket: {err}; running in this process", file=sys.stderr)
        return None
    import signal
    import socket

    try:
        cwd = os.getcwd()
    except FileNotFoundError:   # this directory was removed: in-process, the command says what that does
        return None
    stdio = _stdio()
    # matplotlib (loaded in the server) read its settings from the server's directory; a
    # matplotlibrc in this one is read first by an in-process command
    if stdio is None or os.path.exists("matplotlibrc"):
        return None
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(path)
    except OSError:   # a socket left by a server that was killed: nothing listens
        sock.close()
        return None
    peer_uid = struct.unpack("3i", sock.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, 12))[1]
    if peer_uid != os.getuid():
        print(f"vcnc: not using the server at {path}: it runs as uid {peer_uid}; running in this process",
              file=sys.stderr)
        return None
    umask = os.umask(0)
    os.umask(umask)
    # ignored here (`nohup vcnc ...`, a background job of a script): ignored by the command too
    ignored = [s for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP) if signal.getsignal(s) == signal.SIG_IGN]
    try:
        send(sock, {"op": "run", "key": code_key(), "argv": sys.argv[:1] + args, "prog_name": program_name(),
                    "cwd": cwd, "env": dict(os.environ), "umask": umask, "stdio": stdio,
                    "ignored_signals": ignored}, (0, 1, 2))
        reply, _ = receive(sock)
    except OSError:   # the server went away before it forked: nothing ran
        reply = None
    if reply is None or "stale" in reply:
        if reply and reply["stale"]:
            print(f"vcnc: {reply['stale']}; running in this process", file=sys.stderr)
        sock.close()
        return None

    def forward(signum, _frame):
        send(sock, {"signal": signum})

    def suspend(_signum, _frame):   # Ctrl-Z: stop the command, then this process, as the shell expects
        send(sock, {"signal": signal.SIGSTOP})
        signal.signal(signal.SIGTSTP, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGTSTP)
        signal.signal(signal.SIGTSTP, suspend)   # continued (fg, bg): so is the command
        send(sock, {"signal": signal.SIGCONT})

    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        if signum not in ignored:
            signal.signal(signum, forward)
    if signal.getsignal(signal.SIGTSTP) != signal.SIG_IGN:
        signal.signal(signal.SIGTSTP, suspend)
    while reply is not None and "status" not in reply:
        try:
            reply, _ = receive(sock)
        except OSError:
            reply = None
    if reply is None:
        print("vcnc: the server ended before the command did (vcnc serve stopped?)", file=sys.stderr)
        return 1
    status = reply["status"]
    if os.WIFSIGNALED(status):   # die of the child's signal, as the shell would have seen it
        signum = os.WTERMSIG(status)
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)
        return 128 + signum
    return os.waitstatus_to_exitcode(status)


def main() -> None:
    args = sys.argv[1:]
    if os.environ.get("VCNC_NO_SERVER", "") in ("", "0") and command_name(args) in FORWARDED:
        code = run_served(args)
        if code is not None:
            sys.stdout.flush()
            os._exit(code)
    from machine.cli import main as run_here

    run_here()


if __name__ == "__main__":
    main()
