"""A small lab of Linux network namespaces for tests: several "hosts" on one private /24, all
inside namespaces the test creates, so no packet reaches the machine's own network.

::

    hub namespace                       host namespaces
    br0 10.77.42.1/24 --- veth --- eth0 10.77.42.2/24   (first host)
        |------------------ veth --- eth0 10.77.42.3/24   (second host) ...

The hub holds a bridge with the subnet's first address; every other host gets one veth pair,
its own end (``eth0``) addressed in the subnet, the hub's end on the bridge. Nothing is added
to the root namespace: both ends of each pair are created directly in their namespaces.
:meth:`Lab.link_down` / :meth:`Lab.link_up` switch a host's ``eth0`` inside its namespace
(the cable is cut: no RST, no FIN; the peers notice only by their Zenoh lease).

Use it as a context manager; on exit every namespace it made is deleted (which deletes its
links), also after errors. Namespaces are named ``skm-<pid>-<host>``; ones left by a test
process that no longer runs (killed with SIGKILL) are deleted at the next start.

Processes run in a namespace through this file as a launcher: ``python netns.py exec NS ARGS``
enters NS (``setns``) and execs ``python ARGS`` in place, so the PID the test holds is the
Python process itself and the test ends it by that PID (see ``procs.Child``).

:func:`unavailable` says why a lab cannot be built here (not root, no ``ip``, no netns support),
for ``pytest.skip``.
"""

from __future__ import annotations

import ctypes
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType

__all__ = ["LAUNCHER", "Lab", "unavailable"]

LAUNCHER = Path(__file__).resolve()
SUBNET = "10.77.42"  # private, and only ever inside the lab's namespaces
_CLONE_NEWNET = 0x40000000
_PREFIX = "skm-"
_IP_TIMEOUT = 15.0


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(
        ["ip", *args], capture_output=True, text=True, timeout=_IP_TIMEOUT, check=False
    )
    if check and result.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)} failed: {result.stderr.strip()}")
    return result


def unavailable() -> str | None:
    """Why network namespaces cannot be used here, or None when they can (checked by making
    and deleting one)."""
    if not sys.platform.startswith("linux"):
        return f"network namespaces need Linux, not {sys.platform}"
    if os.geteuid() != 0:
        return "network namespaces need root (run the netns tests as root, e.g. in CI)"
    if shutil.which("ip") is None:
        return "the `ip` command is missing (Debian package iproute2)"
    probe = f"{_PREFIX}{os.getpid()}-probe"
    made = _ip("netns", "add", probe, check=False)
    if made.returncode != 0:
        return f"cannot create a network namespace: {made.stderr.strip()}"
    _ip("netns", "del", probe, check=False)
    return None


def _stale() -> list[str]:
    """Lab namespaces of test processes that are gone."""
    names = [line.split()[0] for line in _ip("netns", "list").stdout.splitlines() if line]
    stale = []
    for name in names:
        m = re.fullmatch(rf"{_PREFIX}(\d+)-.+", name)
        if m and not Path(f"/proc/{m.group(1)}").exists():
            stale.append(name)
    return stale


class Lab:
    """Namespaces ``hosts`` on one /24: ``hosts[0]`` is the hub (address ``.1``, the bridge),
    the others ``.2``, ``.3``, ... in order."""

    def __init__(self, hosts: Sequence[str]) -> None:
        if len(hosts) < 2 or len(set(hosts)) != len(hosts):
            raise ValueError(f"a lab needs two or more distinct hosts, not {hosts!r}")
        for host in hosts:
            if not re.fullmatch(r"[a-z0-9]{1,10}", host):
                raise ValueError(f"host names are 1-10 lowercase letters/digits, not {host!r}")
        self.hosts = tuple(hosts)
        self.hub = hosts[0]
        self._made: list[str] = []

    def ns(self, host: str) -> str:
        """The namespace name of ``host``."""
        return f"{_PREFIX}{os.getpid()}-{host}"

    def address(self, host: str) -> str:
        """``host``'s IPv4 address in the lab."""
        return f"{SUBNET}.{self.hosts.index(host) + 1}"

    def __enter__(self) -> Lab:
        try:
            for name in _stale():
                _ip("netns", "del", name, check=False)
            for host in self.hosts:
                _ip("netns", "add", self.ns(host))
                self._made.append(self.ns(host))
                self.ip(host, "link", "set", "lo", "up")
            hub = self.ns(self.hub)
            self.ip(self.hub, "link", "add", "br0", "type", "bridge")
            self.ip(self.hub, "addr", "add", f"{self.address(self.hub)}/24", "dev", "br0")
            self.ip(self.hub, "link", "set", "br0", "up")
            for i, host in enumerate(self.hosts[1:], start=1):
                port = f"p{i}"
                self.ip(
                    host, "link", "add", "eth0", "type", "veth", "peer", "name", port, "netns", hub
                )
                self.ip(self.hub, "link", "set", port, "master", "br0")
                self.ip(self.hub, "link", "set", port, "up")
                self.ip(host, "addr", "add", f"{self.address(host)}/24", "dev", "eth0")
                self.ip(host, "link", "set", "eth0", "up")
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(
        self, et: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def close(self) -> None:
        """Delete every namespace made (their links go with them). Idempotent."""
        while self._made:
            _ip("netns", "del", self._made.pop(), check=False)

    def ip(self, host: str, *args: str) -> str:
        """Run ``ip ARGS`` inside ``host``'s namespace; returns its output."""
        return _ip("-n", self.ns(host), *args).stdout

    def link_down(self, host: str) -> None:
        """Cut ``host``'s cable: its ``eth0`` goes down inside its namespace."""
        self.ip(host, "link", "set", "eth0", "down")

    def link_up(self, host: str) -> None:
        self.ip(host, "link", "set", "eth0", "up")

    def python(self, host: str, *args: str) -> list[str]:
        """Arguments for ``procs.Child`` (which prepends ``sys.executable``) that run
        ``python ARGS`` inside ``host``'s namespace."""
        return [str(LAUNCHER), "exec", self.ns(host), *args]

    def wait_for_port(self, host: str, address: str, port: int, timeout: float = 10.0) -> None:
        """Block until a TCP connection from ``host`` to ``address:port`` succeeds (a listener
        is up), polling every 50 ms; AssertionError after ``timeout`` seconds."""
        code = (
            "import socket, sys, time\n"
            f"deadline = time.monotonic() + {timeout!r}\n"
            "while True:\n"
            "    try:\n"
            f"        socket.create_connection(({address!r}, {port}), timeout=0.5).close()\n"
            "        break\n"
            "    except OSError:\n"
            "        if time.monotonic() > deadline: sys.exit('no listener')\n"
            "        time.sleep(0.05)\n"
        )
        done = self.run(host, "-c", code, timeout=timeout + 20)
        assert done.returncode == 0, f"{host}: nothing listens on {address}:{port}: {done.stderr}"

    def run(self, host: str, *args: str, timeout: float = 30.0) -> subprocess.CompletedProcess[str]:
        """Run ``python ARGS`` in ``host``'s namespace to its end (bounded by ``timeout``)."""
        return subprocess.run(
            [sys.executable, *self.python(host, *args)],
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )


def _exec_in(ns: str, args: list[str]) -> None:
    """Enter network namespace ``ns`` and replace this process by ``python ARGS``."""
    libc = ctypes.CDLL(None, use_errno=True)
    fd = os.open(f"/var/run/netns/{ns}", os.O_RDONLY)
    if libc.setns(fd, _CLONE_NEWNET) != 0:
        err = ctypes.get_errno()
        raise OSError(err, f"setns({ns}): {os.strerror(err)}")
    os.close(fd)
    os.execv(sys.executable, [sys.executable, *args])


if __name__ == "__main__":
    if len(sys.argv) < 4 or sys.argv[1] != "exec":
        sys.exit("usage: netns.py exec NAMESPACE PYTHON-ARGS...")
    _exec_in(sys.argv[2], sys.argv[3:])
