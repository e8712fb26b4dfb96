"""`vcnc serve` (machine.server) and the `vcnc` entry point that hands it commands (machine.client).

One server for the module, in its own XDG_RUNTIME_DIR. The reference for every command is the
command run in this process by click's CliRunner (as without a server, under the same program
name): stdout, stderr and exit code must be the same bytes; the server's request count says
whether a command went through it.
"""
from __future__ import annotations

import json
import os
import signal
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from machine import client
from machine.cli import main

ROOT = Path(__file__).resolve().parents[2]
DEMO = str(ROOT / "programs" / "demo.nc")
PROG = "python -m machine.client"
# the run's own clock: the only figures that differ between two runs of the same program
TIMINGS = ("wall_s", "check_s", "realtime_factor")


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    runtime = tmp_path_factory.mktemp("run")
    env = dict(os.environ, XDG_RUNTIME_DIR=str(runtime))
    env.pop("VCNC_NO_SERVER", None)
    server = subprocess.Popen([sys.executable, "-m", "machine.cli", "serve"], cwd=ROOT, env=env,
                              stdout=subprocess.PIPE, text=True)
    lines = []
    for line in server.stdout:
        lines.append(line)
        if " ready at " in line:
            break
    else:
        pytest.fail(f"vcnc serve did not start: {''.join(lines)}")
    yield env
    server.send_signal(signal.SIGTERM)
    rest = server.stdout.read()
    assert server.wait() == 0, rest
    assert rest.rstrip().endswith("vcnc serve: stopped")
    assert not list((runtime / "vcnc").iterdir()), "the socket outlives its server"


def vcnc(env: dict, *args: str, **extra) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "machine.client", *args], cwd=ROOT, env=env,
                          capture_output=True, **extra)


def status(env: dict) -> dict:
    """The server's --status, asked over its socket from this process."""
    path = os.path.join(env["XDG_RUNTIME_DIR"], "vcnc", os.path.basename(client.socket_path()))
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.connect(path)
        client.send(sock, {"op": "status"})
        return client.receive(sock)[0]


def served_and_here(env: dict, *args: str) -> tuple[tuple, tuple]:
    """(exit code, stdout, stderr) of the command through the server (asserted to have gone
    through it) and run here."""
    before = status(env)["requests"]
    through = vcnc(env, *args)
    assert status(env)["requests"] == before + 1, "the command did not go through the server"
    here = CliRunner().invoke(main, list(args), prog_name=PROG)
    return (through.returncode, through.stdout, through.stderr), (here.exit_code, here.stdout_bytes, here.stderr_bytes)


def test_parse_table_and_error_the_same_bytes(served, tmp_path):
    through, here = served_and_here(served, "parse", DEMO)
    assert through == here and here[0] == 0 and "─" in here[1].decode()
    bad = tmp_path / "bad.nc"
    bad.write_text("G21 G90\nG1 X1 F100\nG1 X2 Y\nM2\n")
    through, here = served_and_here(served, "parse", str(bad))
    assert through == here and here[0] == 1 and f"{bad}:3:".encode() in here[2]
    through, here = served_and_here(served, "run", str(tmp_path / "missing.nc"))   # usage: exit 2
    assert through == here and here[0] == 2 and f"Usage: {PROG} run".encode() in here[2]


def test_run_and_interp_the_same_output(served, tmp_path):
    traces = [tmp_path / "served.npz", tmp_path / "here.npz"]
    through, here = (served_and_here(served, "run", DEMO, "--json", "--trace", str(t)) for t in traces)
    through, here = through[0], here[1]
    assert (through[0], through[2]) == (here[0], here[2]) == (0, b"")
    a, b = (json.loads(r[1]) for r in (through, here))
    assert {k: v for k, v in a.items() if k not in TIMINGS} == {k: v for k, v in b.items() if k not in TIMINGS}
    with np.load(traces[0]) as x, np.load(traces[1]) as y:
        assert sorted(x.files) == sorted(y.files)
        for name in x.files:
            assert x[name].tobytes() == y[name].tobytes(), name
    through, here = served_and_here(served, "interp", DEMO, "--json")
    a, b = (json.loads(r[1]) for r in (through, here))
    assert (through[0], through[2]) == (here[0], here[2]) == (0, b"")
    assert {k: v for k, v in a.items() if not k.endswith("_s")} == {k: v for k, v in b.items() if not k.endswith("_s")}


def test_compare_the_same_table(served):
    through, here = served_and_here(served, "compare", DEMO, DEMO, "--planner", "grbl", "--planner", "vcnc")
    assert through == here and here[0] == 0 and "largest distance to the other path" in here[1].decode()


def test_stale_server_is_ignored_and_says_so_once(served):
    other = dict(served, NUMBA_OPT="2")   # a setting numba reads when it loads: not the server's
    before = status(served)["requests"]
    first, second = vcnc(other, "parse", "--json", DEMO), vcnc(other, "parse", "--json", DEMO)
    assert status(served)["requests"] == before
    here = CliRunner().invoke(main, ["parse", "--json", DEMO], prog_name=PROG)
    assert first.stdout == second.stdout == here.stdout_bytes
    assert first.stderr.decode() == ("vcnc: the vcnc server (pid %d) runs other code or settings than this vcnc "
                                     "(environment: NUMBA_OPT None in the server, '2' here); restart `vcnc serve`; "
                                     "running in this process\n" % status(served)["pid"])
    assert second.stderr == here.stderr_bytes == b""
    said = vcnc(other, "serve", "--status").stdout.decode()
    assert said.endswith("; it runs other code or settings than this vcnc (environment: NUMBA_OPT None in the "
                         "server, '2' here): restart it\n")


def test_stream_and_grbl_never_go_through_the_server(served, tmp_path):
    assert "stream" not in client.FORWARDED and "grbl" not in client.FORWARDED
    before = status(served)["requests"]
    for args in (["stream", DEMO, "--port", str(tmp_path / "no-such-port")], ["grbl", "--help"],
                 ["--debug", "stream", "--help"]):
        vcnc(served, *args)
    assert status(served)["requests"] == before


def test_a_matplotlibrc_in_the_directory_keeps_the_command_here(served, tmp_path):
    (tmp_path / "matplotlibrc").write_text("lines.linewidth: 3\n")
    before = status(served)["requests"]
    here = subprocess.run([sys.executable, "-m", "machine.client", "parse", "--json", DEMO], cwd=tmp_path,
                          env=served, capture_output=True)
    assert here.returncode == 0 and status(served)["requests"] == before


def test_ctrl_c_reaches_the_command_and_a_gone_client_takes_it_along(served):
    args = ["run", DEMO, "--realtime", "--json"]   # paced: 2.5 s
    run = _paced(served, args)
    run.send_signal(signal.SIGINT)
    out, err = run.communicate()
    _assert_interrupted(run.returncode, out, err)

    killed = _paced(served, args)
    (child,) = status(served)["running"]
    assert os.getsid(child) == child   # its own session: the server's terminal's job control is not its
    killed.kill()
    killed.communicate()
    # the server kills and reaps it once it sees the connection end; on a loaded machine that can
    # take a while (the child's exit frees the server's copied memory), so wait for it, generously
    give_up = time.monotonic() + 60.0
    while status(served)["running"] and time.monotonic() < give_up:
        time.sleep(0.01)
    assert not status(served)["running"], f"the command (pid {child}) outlived its client"
    with pytest.raises(ProcessLookupError):
        os.kill(child, 0)


def test_ignored_signals_stay_ignored_and_ctrl_z_stops_the_command(served, tmp_path):
    program = tmp_path / "a_minute.nc"
    program.write_text("G21 G90 G1 X60 F60\nM2\n")   # paced: 60 s, so no load ends it before the signals
    # a process group of its own under pytest: stopping signals sent to an orphaned group (pytest's own where CI
    # starts it in a new session) are discarded by the kernel, so Ctrl-Z would stop nothing, in-process too
    run = _paced(served, ["run", str(program), "--realtime", "--json"], process_group=0,
                 preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))   # as under nohup
    (child,) = status(served)["running"]
    run.send_signal(signal.SIGTSTP)
    assert _state(run.pid) == _state(child) == "T"
    run.send_signal(signal.SIGHUP)
    run.send_signal(signal.SIGCONT)
    assert _state(child, "T") != "T" and status(served)["running"] == [child], "continued, and SIGHUP ignored"
    run.send_signal(signal.SIGINT)
    out, err = run.communicate()
    _assert_interrupted(run.returncode, out, err)


def _assert_interrupted(code: int, out: bytes, err: bytes) -> None:
    """As in-process: the controller's loop ends the run "interrupted" (exit 130, its summary printed);
    before the loop has begun, click's KeyboardInterrupt: "Aborted!", exit 1."""
    if code == 130:
        assert json.loads(out)["state"] == "interrupted"
    else:
        assert (code, err.splitlines()[-1]) == (1, b"Aborted!")


def _state(pid: int, leaving: str | None = None) -> str:
    """A process's state letter once it has stopped (T), or once it is no longer `leaving`, or
    whatever it is after a generous wait."""
    give_up = time.monotonic() + 60.0
    while True:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        if (state != leaving if leaving else state == "T") or time.monotonic() > give_up:
            return state
        time.sleep(0.01)


def _paced(env: dict, args: list[str], **extra) -> subprocess.Popen:
    """`vcnc ARGS` (a --realtime run) once its pacing has begun (its key help on stderr)."""
    run = subprocess.Popen([sys.executable, "-m", "machine.client", *args], cwd=ROOT, env=env,
                           stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, **extra)
    assert run.stderr.readline().startswith(b"keys: ")
    return run


def test_a_socket_open_to_others_is_refused(tmp_path):
    folder = tmp_path / "vcnc"
    folder.mkdir(mode=0o755)
    folder.chmod(0o755)
    with pytest.raises(client.Refused, match="open to other users"):
        client.check_owned(str(folder), stat.S_IFDIR)
    folder.chmod(0o700)
    client.check_owned(str(folder), stat.S_IFDIR)
    with pytest.raises(client.Refused, match="not a socket"):
        client.check_owned(str(folder), stat.S_IFSOCK)


def test_command_name_skips_the_groups_options():
    assert client.command_name(["--debug", "run", "x.nc"]) == "run"
    assert client.command_name(["--help"]) is None and client.command_name([]) is None


def test_realtime_keys_from_a_terminal_through_the_server(served, tmp_path):
    """Found running `vcnc serve &` and then `vcnc run --realtime` in one terminal: the served child,
    of the server's session, failed with EIO setting the terminal up for keys (now it has a session
    of its own: the Ctrl-C test checks it)."""
    program = tmp_path / "short.nc"
    program.write_text("G21 G90 G1 X1 F6000\nM2\n")   # paced: 10 ms
    main_fd, terminal_fd = os.openpty()
    before = status(served)["requests"]
    try:
        done = vcnc(served, "run", str(program), "--realtime", "--json", stdin=terminal_fd)
    finally:
        os.close(main_fd)
        os.close(terminal_fd)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["position_mm"] == [1.0, 0.0, 0.0]
    assert status(served)["requests"] == before + 1


def test_an_exception_in_the_command_prints_its_traceback_and_exits_1(tmp_path):
    """--debug lets an internal error out of click: the child prints it as Python would, exit 1."""
    from machine import server
    from machine.commands import parse

    out, err = tmp_path / "out", tmp_path / "err"
    # what `python -m machine.client --debug parse DEMO` sends (its argv[0] is the module's path under -m)
    request = {"argv": [client.__file__, "--debug", "parse", DEMO], "prog_name": PROG,
               "cwd": str(tmp_path),
               "env": dict(os.environ), "umask": 0o022, "ignored_signals": [],
               "stdio": [{"encoding": "utf-8", "errors": e, "line_buffering": False, "write_through": False}
                         for e in ("strict", "strict", "backslashreplace")]}
    pid = os.fork()
    if pid == 0:   # a stand-in for the server's child, its command broken on purpose
        def broken(**_):
            raise RuntimeError("boom")

        parse.command.callback = broken
        fds = [os.open(os.devnull, os.O_RDONLY), os.open(out, os.O_WRONLY | os.O_CREAT),
               os.open(err, os.O_WRONLY | os.O_CREAT)]
        try:
            server.run_child(request, fds)
        finally:
            os._exit(99)
    _, status = os.waitpid(pid, 0)
    lines = err.read_text().splitlines()
    assert os.waitstatus_to_exitcode(status) == 1 and out.read_text() == ""
    assert lines[0] == "Traceback (most recent call last):" and lines[-1] == "RuntimeError: boom"

