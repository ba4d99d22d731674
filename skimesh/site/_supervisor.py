"""``skimesh up``: start this host's processes in dependency order, each ready (its probe)
before the next; wait over the mesh for those of other hosts; restart by the site's policy;
stop in reverse order (SIGTERM, SIGKILL after the grace period) on SIGINT / SIGTERM."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from contextlib import AsyncExitStack
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import IO

import anyio

import skimesh
from meshlink import Mesh, MeshConfig, MeshlinkError, open_mesh

from ._plan import Component, Plan
from ._probe import ATTEMPT, probe
from ._restart import describe_exit, restart_delay
from ._state import Row, StateDir, Status

__all__ = ["Supervisor"]

POLL = 0.2
"""Seconds between looks at a child (exit) and between probes."""


@dataclass
class _Proc:
    component: Component
    row: Row
    log: IO[bytes] | None = None
    popen: subprocess.Popen[bytes] | None = None
    ended: anyio.Event | None = None
    """Set when the current process has ended (and was reaped)."""
    restarted_at: list[float] = field(default_factory=list)


class Supervisor:
    """This host's part of a site. :meth:`run` returns the exit code: 0 after a clean stop,
    1 when the site could not come up."""

    def __init__(self, plan: Plan, state: StateDir, show: Callable[[list[Row], str], None]) -> None:
        self.plan, self.state, self.show = plan, state, show
        self.procs = [
            _Proc(c, Row(c.name, c.kind, c.host, "pending", log=self._log_name(c)))
            for c in plan.components
        ]
        self.stopping = False
        self._grace: anyio.CancelScope | None = None
        self._tg: anyio.abc.TaskGroup | None = None
        self.message = ""
        self._dirty: anyio.Event | None = None
        self._writing: anyio.Lock | None = None
        self._up: anyio.CancelScope | None = None
        self._mesh: Mesh | None = None
        self._env = dict(os.environ, PYTHONUNBUFFERED="1")
        source = str(Path(skimesh.__file__).resolve().parents[1])  # this skimesh, in children too
        self._env["PYTHONPATH"] = os.pathsep.join(
            p for p in (source, os.environ.get("PYTHONPATH", "")) if p
        )

    def _log_name(self, c: Component) -> str:
        return str(self.state.log_path(c.name)) if c.host == self.plan.host else ""

    def open_logs(self) -> None:
        """Open each local process's log file (append); call before the event loop runs."""
        for proc in self.procs:
            if proc.row.log:
                proc.log = Path(proc.row.log).open("ab")  # noqa: SIM115  # closed by run()

    # ------------------------------------------------------------------ running

    async def run(self) -> int:
        code = 0
        self._dirty = anyio.Event()
        self._writing = anyio.Lock()
        self._up = anyio.CancelScope()
        async with AsyncExitStack() as stack, anyio.create_task_group() as tg:
            self._tg = tg
            tg.start_soon(self._watch_signals)
            tg.start_soon(self._publish)
            try:
                with self._up:
                    code = await self._bring_up(tg, stack)
                    if code == 0:
                        await self._write()  # the status file says ready before the line does
                        local = len(self.plan.local())
                        self._say(f"site up: {local} processes of host {self.plan.host} ready")
                        await anyio.sleep_forever()
            finally:  # also when something failed here: no process is left behind
                self.stopping = True
                with anyio.CancelScope(shield=True):
                    self._say("stopping")
                    await stack.aclose()
                    await self._stop_all()
                    self._say("stopped")
                    await self._write()
                tg.cancel_scope.cancel()
        for proc in self.procs:
            if proc.log is not None:
                proc.log.close()
        return code

    async def _watch_signals(self) -> None:
        with anyio.open_signal_receiver(signal.SIGINT, signal.SIGTERM) as signals:
            async for signum in signals:
                if self.stopping and self._grace is not None:  # a second Ctrl-C: no more grace
                    self._grace.cancel()
                self._say(f"{signal.Signals(signum).name} received: stopping the site")
                self.stopping = True
                if self._up is not None:
                    self._up.cancel()

    async def _bring_up(self, tg: anyio.abc.TaskGroup, stack: AsyncExitStack) -> int:
        site = self.plan.site
        for proc in self.procs:
            c, row = proc.component, proc.row
            if c.kind != "router" and self._mesh is None:
                try:
                    self._mesh = await stack.enter_async_context(open_mesh(self._mesh_config()))
                except MeshlinkError as e:
                    self.message = f"cannot join the mesh to probe {c.name}: {e}"
                    return 1
            if c.host != self.plan.host:
                self._set(row, "waiting", f"on host {c.host}: waiting for it over the mesh")
                why = await self._until_ready(proc, site.remote_timeout)
                if why:
                    self._set(row, "unreachable", why)
                    self.message = (
                        f"{c.name} (host {c.host}) not ready after {site.remote_timeout:g} s: "
                        f"{why}; is `skimesh up SITE --host {c.host}` running there?"
                    )
                    return 1
                self._set(row, "ready", f"on host {c.host}")
                continue
            self._spawn(proc)
            why = await self._until_ready(proc, site.ready_timeout)
            if why:
                self._set(row, "failed", why)
                self.message = f"{c.name} did not come up: {why} (log: {row.log})"
                return 1
            self._set(row, "ready", "")
            tg.start_soon(self._keep, proc)
        return 0

    def _mesh_config(self) -> MeshConfig:
        plan = self.plan
        return MeshConfig(connect=plan.connect, mesh=plan.site.mesh, config_file=plan.probe_config)

    async def _until_ready(self, proc: _Proc, timeout: float) -> str:
        """``""`` once ``proc``'s probe passes, else why not when its process ended or the time
        ran out."""
        deadline = time.monotonic() + timeout
        why = "not probed yet"
        while time.monotonic() < deadline:
            popen, ended = proc.popen, proc.ended
            if popen is not None and ended is not None and ended.is_set():
                return f"{describe_exit(popen.returncode)} before it was ready"
            why = await probe(proc.component, self._mesh)
            if not why:
                return ""
            if proc.row.detail != why and proc.row.state in ("starting", "waiting"):
                proc.row.detail = why
                self._changed()
            await anyio.sleep(POLL)
        return f"{why} (after {timeout:g} s)"

    def _spawn(self, proc: _Proc) -> None:
        """Start ``proc``'s process (no await between the check and the start: a stop that
        began cannot miss it)."""
        if self.stopping:
            return
        assert proc.log is not None
        stamp = time.strftime("%Y-%m-%d %H:%M:%S")
        argv = [sys.executable, "-m", "skimesh", *proc.component.argv]
        proc.log.write(f"=== {stamp} skimesh up: {' '.join(argv)}\n".encode())
        proc.log.flush()
        proc.popen = subprocess.Popen(
            argv,
            cwd=self.state.path,
            stdin=subprocess.DEVNULL,
            stdout=proc.log,
            stderr=subprocess.STDOUT,
            env=self._env,
            start_new_session=True,  # the terminal's Ctrl-C reaches `skimesh up` only
        )
        proc.row.pid = proc.popen.pid
        proc.ended = anyio.Event()
        assert self._tg is not None
        self._tg.start_soon(self._reap, proc.popen, proc.ended)
        self._set(proc.row, "starting", "")

    async def _keep(self, proc: _Proc) -> None:
        """Follow a ready process; restart it by the policy when it ends."""
        policy, row = self.plan.site.restart, proc.row
        while True:
            popen, ended = proc.popen, proc.ended
            assert popen is not None and ended is not None
            await ended.wait()
            if self.stopping:
                return
            now, why = time.monotonic(), describe_exit(popen.returncode)
            delay = restart_delay(policy, popen.returncode, proc.restarted_at, now)
            if delay is None:
                state = "exited" if popen.returncode == 0 else "failed"
                self._set(row, state, f"{why}; not restarted (restart policy {policy.policy})")
                return
            proc.restarted_at.append(now)
            row.restarts += 1
            self._set(row, "restarting", f"{why}; restart {row.restarts} in {delay:g} s")
            await anyio.sleep(delay)
            if self._stopped():
                return
            self._spawn(proc)
            why = await self._until_ready(proc, self.plan.site.ready_timeout)
            self._set(row, "ready" if not why else "unready", why)

    def _stopped(self) -> bool:
        return self.stopping

    async def _reap(self, popen: subprocess.Popen[bytes], ended: anyio.Event) -> None:
        await anyio.to_thread.run_sync(popen.wait, abandon_on_cancel=True)
        ended.set()

    async def _stop_all(self) -> None:
        grace = self.plan.site.stop_grace
        for proc in reversed(self.procs):
            popen, ended = proc.popen, proc.ended
            if popen is None or ended is None or ended.is_set():
                continue
            self._set(proc.row, "stopping", "SIGTERM")
            popen.send_signal(signal.SIGTERM)
            with anyio.move_on_after(grace) as waited:
                self._grace = waited
                await ended.wait()
            if not ended.is_set():
                self._set(proc.row, "stopping", "no stop in time: SIGKILL")
                popen.kill()
                await ended.wait()
            self._set(proc.row, "stopped", describe_exit(popen.returncode))

    # ------------------------------------------------------------------ status

    def _set(self, row: Row, state: str, detail: str) -> None:
        row.state, row.detail = state, detail
        self.show(self.rows(), "")
        self._changed()

    def _changed(self) -> None:
        if self._dirty is not None:
            self._dirty.set()

    def _say(self, text: str) -> None:
        self.show(self.rows(), text)

    def rows(self) -> list[Row]:
        return [p.row for p in self.procs]

    async def _publish(self) -> None:
        while self._dirty is not None:
            await self._dirty.wait()
            self._dirty = anyio.Event()
            await self._write()
            await anyio.sleep(ATTEMPT / 10)

    async def _write(self) -> None:
        """Write the status file (one writer at a time: each replaces it whole)."""
        assert self._writing is not None
        async with self._writing:
            rows = [replace(r) for r in self.rows()]  # copies: the thread reads them
            status = Status(os.getpid(), self.plan.host, str(self.plan.path), rows)
            await anyio.to_thread.run_sync(self.state.write_status, status)
