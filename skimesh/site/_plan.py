"""From a site file to a plan: every component, its host, its command line, its readiness
probe, in start order; checked (unknown hosts and scenarios, components on no host, ports
that clash, robots served twice) with errors that say what to change."""

from __future__ import annotations

import socket
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import msgspec

from ._endpoint import ANY_ADDRESS, parse_endpoint
from ._errors import SiteError
from ._schema import Agents, Router, Site
from ._secure import OPERATOR, SiteSecurityPlan, security_of, tls

__all__ = ["Component", "Plan", "load_site", "make_plan", "pick_host"]

Kind = Literal["router", "store", "sim", "agents", "task-agent", "monitor", "eventlog"]
_LOCAL = "local"


@dataclass(frozen=True)
class Component:
    """One process of the site."""

    name: str
    kind: Kind
    host: str
    argv: tuple[str, ...]
    """Its ``skimesh`` sub-command and options (run as ``python -m skimesh ARGV``)."""
    ready: tuple[str, ...]
    """Its probe: ``("tcp", address, port)``, ``("store",)``, ``("devices",)``,
    ``("agents", name, ...)``, ``("tasks",)``, ``("eventlog",)`` or ``()`` (no probe: the
    monitor, ready once it runs)."""
    serves: tuple[tuple[str, str], ...] = ()
    """An agents process: (agent, its robot's label) of each agent it serves."""


@dataclass(frozen=True)
class Plan:
    """The site seen from one host."""

    site: Site
    path: Path
    host: str
    components: tuple[Component, ...]
    """Every component of every host, in start order."""
    connect: tuple[str, ...]
    """The router endpoints this host's processes connect to."""
    security: SiteSecurityPlan | None = None
    """Where the credentials are, on a secure site (None: an open mesh)."""

    @property
    def probe_config(self) -> str | None:
        """The Zenoh config of ``skimesh up``'s own session (health checks, status)."""
        if self.security is not None:
            return self.security.client(OPERATOR)
        zenoh = self.site.zenoh_config
        return str(self.path.parent / zenoh) if zenoh else None

    def local(self) -> list[Component]:
        return [c for c in self.components if c.host == self.host]


def load_site(path: Path | str) -> Site:
    """Decode a site file strictly; SiteError names the file and the key path."""
    path = Path(path)
    try:
        text = path.read_bytes()
    except OSError as e:
        raise SiteError(f"cannot read site file {path}: {e.strerror}") from None
    try:
        return msgspec.toml.decode(text, type=Site)
    except msgspec.ValidationError as e:
        raise SiteError(f"{path}: {e}") from None
    except msgspec.DecodeError as e:
        raise SiteError(f"{path}: not TOML: {e}") from None


def _hosts(site: Site) -> list[str]:
    return sorted(site.hosts) or [_LOCAL]


def pick_host(site: Site, wanted: str | None) -> str:
    """``wanted`` if the site has it; else this machine's hostname, or the only host."""
    hosts = _hosts(site)
    if wanted:
        if wanted not in hosts:
            raise SiteError(f"no host {wanted!r} in the site; its hosts: {', '.join(hosts)}")
        return wanted
    if len(hosts) == 1:
        return hosts[0]
    me = socket.gethostname()
    for name in (me, me.split(".")[0]):
        if name in hosts:
            return name
    raise SiteError(
        f"this machine ({me}) is none of the site's hosts ({', '.join(hosts)}): give --host NAME"
    )


def make_plan(
    site: Site, path: Path, host: str | None = None, *, listen: list[str] | None = None
) -> Plan:
    """Check ``site`` and plan it from ``host`` (see :func:`pick_host`). ``listen`` replaces
    the listen endpoints of the site's only router (a rehearsal on another port)."""
    if listen:
        if len(site.routers) != 1:
            raise SiteError("--listen replaces the endpoints of a site's only router")
        site = msgspec.structs.replace(
            site, routers=[msgspec.structs.replace(site.routers[0], listen=list(listen))]
        )
    me = pick_host(site, host)
    return _Planner(site, path, me).plan()


class _Planner:
    def __init__(self, site: Site, path: Path, me: str) -> None:
        self.site, self.path, self.me = site, path.resolve(), me
        self.hosts = _hosts(site)
        self.names: set[str] = set()
        self.scenario_ref = self._scenario(site.scenario) if site.scenario else ""
        self.security = security_of(site, self.path)
        if self.security is not None and site.zenoh_config:
            raise SiteError(
                "`zenoh_config` and `security` both configure the processes' Zenoh: leave "
                'out `zenoh_config`, or set `security = "none"` and bring your own'
            )

    def file(self, name: str) -> str:
        return str((self.path.parent / name).resolve())

    def host_of(self, what: str, host: str) -> str:
        if not host:
            if len(self.hosts) == 1:
                return self.hosts[0]
            raise SiteError(f"{what} is on no host: set `host` to one of {', '.join(self.hosts)}")
        if host not in self.hosts:
            raise SiteError(
                f"{what}: unknown host {host!r}; the site's hosts: {', '.join(self.hosts)}"
            )
        return host

    def name(self, wanted: str, default: str) -> str:
        name = wanted or default
        if not wanted and name in self.names:
            name = next(
                f"{default}-{i}" for i in range(2, 1000) if f"{default}-{i}" not in self.names
            )
        if name in self.names:
            raise SiteError(f"two components are named {name!r}: give one another `name`")
        self.names.add(name)
        return name

    def _scenario(self, ref: str) -> str:
        from scenario import ScenarioError

        from ..paths import read_scenario

        local = self.path.parent / ref
        if ref.endswith(".toml") or "/" in ref:
            if not local.is_file():
                raise SiteError(f"no scenario file {local}")
            ref = str(local.resolve())
        try:
            read_scenario(ref)
        except (ScenarioError, FileNotFoundError) as e:
            raise SiteError(f"scenario {ref!r}: {e}") from None
        return ref

    # ------------------------------------------------------------------ endpoints

    def endpoint_for(self, host: str) -> str:
        """The router endpoint processes on ``host`` connect to: their host's router, else
        the first."""
        mine = [r for r in self.site.routers if self.host_of("a router", r.host) == host]
        return self.reach(mine[0] if mine else self.site.routers[0], host)

    def reach(self, router: Router, host: str) -> str:
        """``router``'s first listen endpoint as seen from ``host``."""
        proto, addr, port = parse_endpoint(router.listen[0])
        router_host = self.host_of("a router", router.host)
        if addr in ANY_ADDRESS:
            if router_host == host:
                addr = "127.0.0.1"
            else:
                addr = (
                    self.site.hosts[router_host].address if router_host in self.site.hosts else ""
                )
                if not addr:
                    raise SiteError(
                        f"the router on {router_host} listens on every interface: give "
                        f"[hosts.{router_host}] an `address` for the other hosts"
                    )
        return tls(f"{proto}/{addr}:{port}") if self.security else f"{proto}/{addr}:{port}"

    def client(self, host: str, name: str) -> list[str]:
        args = ["--connect", self.endpoint_for(host), "--mesh", self.site.mesh]
        if self.security is not None:
            args += ["--config", self.security.client(name)]
        elif self.site.zenoh_config:
            args += ["--config", self.file(self.site.zenoh_config)]
        return args

    # ------------------------------------------------------------------ components

    def plan(self) -> Plan:
        try:
            from meshlink import check_name

            check_name(self.site.mesh, "mesh name")
        except ValueError as e:
            raise SiteError(str(e)) from None
        out = [*self.routers()]
        out += self.store()
        out += self.sim()
        out += self.agents()
        out += self.task_agent()
        out += self.eventlog()
        out += self.monitor()
        connect = (self.endpoint_for(self.me),)
        return Plan(self.site, self.path, self.me, tuple(out), connect, self.security)

    def routers(self) -> list[Component]:
        out: list[Component] = []
        bound: dict[tuple[str, int], tuple[str, str]] = {}
        for router in self.site.routers:
            host = self.host_of("a router", router.host)
            name = self.name(router.name, "router")
            for endpoint in router.listen:
                _, addr, port = parse_endpoint(endpoint)
                for (other_host, other_port), (other, other_addr) in bound.items():
                    same = addr == other_addr or addr in ANY_ADDRESS or other_addr in ANY_ADDRESS
                    if other_host == host and other_port == port and same:
                        raise SiteError(
                            f"ports clash on host {host}: {name} and {other} both listen on "
                            f"port {port}"
                        )
                bound[(host, port)] = (name, addr)
            for endpoint in router.connect:
                parse_endpoint(endpoint)
            wrap = tls if self.security else str
            argv = ["router", *(a for e in router.listen for a in ("--listen", wrap(e)))]
            argv += [a for e in router.connect for a in ("--connect", wrap(e))]
            if self.security is not None:
                argv += ["--config", self.security.router()]
            elif router.zenoh_config:
                argv += ["--config", self.file(router.zenoh_config)]
            probe = parse_endpoint(self.reach(router, self.me))
            out.append(
                Component(name, "router", host, tuple(argv), ("tcp", probe[1], str(probe[2])))
            )
        return out

    def store(self) -> list[Component]:
        store = self.site.store
        if store is None:
            return []
        host, name = self.host_of("the store", store.host), self.name("", "store")
        argv = ["wm", *self.client(host, name), "--data", store.data]
        argv += ["--durability", store.durability]
        scenario = self._scenario(store.scenario) if store.scenario else self.scenario_ref
        if scenario:
            argv += ["--scenario", scenario]
        argv += [a for f in store.ontology for a in ("--ontology", self.file(f))]
        return [Component(name, "store", host, tuple(argv), ("store",))]

    def need_scenario(self, what: str) -> str:
        if not self.scenario_ref:
            raise SiteError(f"{what} needs the site's `scenario`")
        return self.scenario_ref

    def sim(self) -> list[Component]:
        sim = self.site.sim
        if sim is None:
            return []
        host, name = self.host_of("the simulator", sim.host), self.name("", "sim")
        argv = ["sim", *self.client(host, name), "--scenario", self.need_scenario("the simulator")]
        argv += ["--fast"] if sim.fast else []
        argv += ["--rerun", sim.rerun] if sim.rerun else ["--no-rerun"]
        return [Component(name, "sim", host, tuple(argv), ("devices",))]

    def agents(self) -> list[Component]:
        out: list[Component] = []
        served: dict[str, str] = {}
        for group in self.site.agents:
            host = self.host_of("an agents process", group.host)
            names, argv, default, robots = self._agent_group(group)
            name = self.name(group.name, default)
            for agent in names:
                if agent in served:
                    raise SiteError(f"agent {agent} is served twice: by {served[agent]} and {name}")
                served[agent] = name
            argv = ["agent", *self.client(host, name), *argv]
            argv += ["--simulate"] if group.simulate else []
            serves = tuple(zip(names, robots, strict=True))
            out.append(Component(name, "agents", host, tuple(argv), ("agents", *names), serves))
        return out

    def _agent_group(self, group: Agents) -> tuple[list[str], list[str], str, list[str]]:
        """(agent names, arguments, default component name, each agent's robot label) of one
        agents process."""
        from skill_agent import SkillError
        from skill_agent.runtime import load_config

        if bool(group.robots) == bool(group.configs):
            raise SiteError("an [[agents]] table needs `robots` or `configs` (one of them)")
        try:
            if group.configs:
                files = [self.file(f) for f in group.configs]
                configs = [load_config(f) for f in files]
                names = [c.name for c in configs]
                return (
                    names,
                    [a for f in files for a in ("--agent-config", f)],
                    "agents-" + "-".join(names),
                    [c.robot.label or c.name for c in configs],
                )
            from ..paths import read_scenario

            scenario = self.need_scenario("an [[agents]] table with `robots`")
            known = read_scenario(scenario).agents
            robots = sorted(known) if group.robots == ["all"] else list(group.robots)
            unknown = [r for r in robots if r not in known]
            if unknown:
                raise SiteError(
                    f"scenario {self.site.scenario!r} has no agent for {', '.join(unknown)}; "
                    f"it has: {', '.join(sorted(known)) or 'none'}"
                )
            configs = [load_config(known[r]) for r in robots]
        except SkillError as e:
            raise SiteError(f"agent config: {e}") from None
        names = [c.name for c in configs]
        argv = ["--scenario", scenario, *(a for r in robots for a in ("--robot", r))]
        return names, argv, "agents-" + "-".join(names), [c.robot.label or c.name for c in configs]

    def task_agent(self) -> list[Component]:
        task = self.site.task_agent
        if task is None:
            return []
        host, name = self.host_of("the task agent", task.host), self.name("", "task-agent")
        argv = ["task-agent", *self.client(host, name), "--durations", "durations.json"]
        argv += ["--operator", task.operator] if task.operator else []
        return [Component(name, "task-agent", host, tuple(argv), ("tasks",))]

    def monitor(self) -> list[Component]:
        monitor = self.site.monitor
        if monitor is None:
            return []
        host, name = self.host_of("the monitor", monitor.host), self.name("", "monitor")
        argv = [
            "monitor",
            *self.client(host, name),
            "--scenario",
            self.need_scenario("the monitor"),
        ]
        argv += ["--rrd", monitor.rrd] + (["--serve-web"] if monitor.serve_web else [])
        return [Component(name, "monitor", host, tuple(argv), ())]

    def eventlog(self) -> list[Component]:
        log = self.site.eventlog
        if log is None:
            return []
        host, name = self.host_of("the event log", log.host), self.name("", "eventlog")
        argv = ["eventlog", *self.client(host, name), "--data", log.data]
        argv += [] if self.site.store is not None else ["--no-wm"]
        return [Component(name, "eventlog", host, tuple(argv), ("eventlog",))]
