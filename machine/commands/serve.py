"""`vcnc serve`: keep vcnc started and its kernels loaded, so each `vcnc` command skips start-up.

Runs in the foreground until Ctrl-C or `vcnc serve --stop`; nothing starts it by itself.
How it works and what it refuses: machine.server and machine.client.
"""
from __future__ import annotations

import json
import socket
import stat
import sys
import time

import click

from machine import client


@click.command("serve")
@click.option("--status", is_flag=True, help="Say whether a server of this install runs, and what it has done.")
@click.option("--stop", is_flag=True, help="Stop the running server (once its running commands end).")
@click.option("--json", "as_json", is_flag=True, help="--status as JSON.")
def command(status: bool, stop: bool, as_json: bool) -> None:
    """Keep vcnc loaded and run offline commands for `vcnc` (start-up paid once)."""
    path = client.socket_path()
    if status or stop:
        reply = _ask(path, "stop" if stop else "status")
        if as_json:
            click.echo(json.dumps(reply))
        elif reply is None:
            click.echo(f"no vcnc server of this install runs ({path})")
        else:
            age_s = time.time() - reply["started"]
            click.echo(f"vcnc server pid {reply['pid']} at {path}: up {age_s:.0f} s, {reply['requests']} "
                       f"command(s) served ({reply['children_cpu_s']:.2f} s CPU), {len(reply['running'])} running"
                       + ("; stopping" if stop or reply["stopping"] else "")
                       + (f"; it runs other code or settings than this vcnc ({reply['differs']}): restart it"
                          if reply.get("differs") else ""))
        if reply is None and stop:
            sys.exit(1)
        return
    from machine import server

    def log(text: str) -> None:
        click.echo(f"vcnc serve: {text}")
        sys.stdout.flush()   # before each fork: a child must not inherit unwritten server output

    try:
        server.check_free(path)
        log("loading vcnc and its kernels (a fresh kernel cache compiles them: minutes)")
        server.warm(log)
        if server.threads() != 1:
            raise click.ClickException(f"{server.threads()} threads after warming: forking would be unsafe")
        served = server.Server(server.listen(path), client.code_key(), log)
    except (server.ServerError, client.Refused) as err:
        raise click.ClickException(str(err)) from None
    log(f"ready at {path} (pid {served.status()['pid']}); Ctrl-C or `vcnc serve --stop` ends it")
    served.serve()
    log("stopped")


def _ask(path: str, op: str) -> dict | None:
    """The server's reply to op, or None if none listens."""
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        client.check_owned(path, stat.S_IFSOCK)
        sock.connect(path)
        client.send(sock, {"op": op, "key": client.code_key()})
        reply, _ = client.receive(sock)
        return reply
    except (OSError, client.Refused):
        return None
    finally:
        sock.close()
