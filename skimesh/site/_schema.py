"""The site file (TOML): which processes a site runs and on which host (strict; pure).

Example (every key in ``docs/reference/site.md``)::

    mesh = "kitting"
    scenario = "kitting"

    [hosts.server]
    address = "10.1.2.3"
    [hosts.robots]

    [[routers]]
    host = "server"
    listen = ["tcp/0.0.0.0:7447"]

    [store]
    host = "server"

    [[agents]]
    host = "robots"
    robots = ["all"]

    [task_agent]
    host = "server"
"""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta, Struct

__all__ = [
    "Agents",
    "EventLog",
    "Host",
    "Monitor",
    "Restart",
    "Router",
    "Sim",
    "Site",
    "Store",
    "TaskAgent",
]

Seconds = Annotated[float, Meta(gt=0)]
Name = Annotated[str, Meta(pattern=r"^([a-z0-9][a-z0-9_-]{0,31})?$")]


class Host(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A machine of the site, named by its key (`[hosts.server]`).

    Attributes:
        address: The address other hosts reach it at (an IP address or a DNS name). Needed
            when a router on this host listens on every interface (`0.0.0.0`) and processes on
            other hosts connect to it; `skimesh up --host NAME` runs this host's part.
    """

    address: str = ""


class Router(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A Zenoh router (`skimesh router`). Processes on a host with a router connect to it;
    processes on other hosts connect to the first router.

    Attributes:
        host: The host that runs it (a key of `[hosts]`; may be left out on a one-host site).
        listen: Its listen endpoints, `tcp/ADDRESS:PORT` (also `tls/`); ready when the first
            accepts a TCP connection.
        connect: Endpoints of other routers it links to (one router per host, linked).
        zenoh_config: A Zenoh JSON5 file for it (`--config`), relative to the site file.
        name: The component's name in status lines and its log file (default `router`, then
            `router-2`, ...).
    """

    listen: Annotated[list[str], Meta(min_length=1)]
    host: str = ""
    connect: list[str] = []
    zenoh_config: str = ""
    name: Name = ""


class Store(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The world-model store (`skimesh wm`); ready when it answers an info request.

    Attributes:
        host: The host that runs it (may be left out on a one-host site).
        data: Its durable directory (write-ahead log and snapshots), relative to the state
            directory of the host (`--state-dir`).
        scenario: The scenario whose scene it loads when it first starts (default: the
            site's `scenario`; `""` with no site scenario: an empty world model).
        ontology: Turtle files of terms it is taught at its start, relative to the site file.
        durability: When a transaction is on disk before its reply: `group` (group commit)
            or `fsync` (one fsync per transaction).
    """

    host: str = ""
    data: str = "wm"
    scenario: str = ""
    ontology: list[str] = []
    durability: Literal["group", "fsync"] = "group"


class Sim(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The MuJoCo simulator (`skimesh sim`) of the site's scenario; leave the table out on
    real hardware. Ready when its devices answer on the mesh.

    Attributes:
        host: The host that runs it (may be left out on a one-host site).
        fast: Step as fast as possible instead of in real time (rehearsals, tests).
        rerun: Record the world to this .rrd file, relative to the state directory (`""`: no
            recording).
    """

    host: str = ""
    fast: bool = False
    rerun: str = ""


class Agents(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One `skimesh agent` process serving one or more skill agents (one Zenoh session).
    Ready when every agent's liveliness token is on the mesh (it is declared once the agent
    has registered in the world model).

    Attributes:
        host: The host that runs the process (may be left out on a one-host site).
        robots: Robots or appliances of the scenario whose agents it serves (`["all"]`: every
            agent the scenario names).
        configs: Agent config files instead of `robots`, relative to the site file.
        simulate: Simulated outcomes, no hardware and no simulator (`--simulate`).
        name: The component's name (default `agents-` and the robots, e.g. `agents-r1-r2`).
    """

    host: str = ""
    robots: list[str] = []
    configs: list[str] = []
    simulate: bool = False
    name: Name = ""


class TaskAgent(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The task agent (`skimesh task-agent`); ready when it answers a task listing.

    Attributes:
        host: The host that runs it (may be left out on a one-host site).
        operator: The operator agent's name (`--operator`; `""`: the task agent's default).
    """

    host: str = ""
    operator: str = ""


class Monitor(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A site monitor (`skimesh monitor`): the whole mesh recorded to rerun with the demo's
    layout, the world posed from the devices' states.

    Attributes:
        host: The host that runs it (may be left out on a one-host site).
        rrd: The recording it writes, relative to the state directory of its host.
        serve_web: Also serve rerun's web viewer from that host (port 9090).
    """

    host: str = ""
    rrd: str = "monitor.rrd"
    serve_web: bool = False


class EventLog(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The site event log (`skimesh eventlog`): every task, run, agent, device and
    world-model event of the mesh in one SQLite file, read with `skimesh events` from any host.

    Attributes:
        host: The host that runs it (may be left out on a one-host site).
        data: Its SQLite file, relative to the state directory of its host.
    """

    host: str = ""
    data: str = "events.sqlite"


class Restart(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """When `skimesh up` starts a process of its host again after it ended by itself.

    Attributes:
        policy: `no`: never; `on-failure`: after an exit with a non-zero code or by a signal
            `skimesh up` did not send (SIGKILL by the OOM killer, a crash); `always`: also
            after a clean exit.
        backoff (s): The wait before the first restart; it doubles with each restart within
            `window`, up to `max_backoff`.
        max_backoff (s): The longest wait between restarts.
        max_restarts: At most this many restarts within `window` seconds; the next end leaves
            the component `failed` (the rest of the site keeps running).
        window (s): The sliding window `max_restarts` counts in.
    """

    policy: Literal["no", "on-failure", "always"] = "on-failure"
    backoff: Seconds = 1.0
    max_backoff: Seconds = 30.0
    max_restarts: Annotated[int, Meta(ge=0)] = 5
    window: Seconds = 300.0


class Site(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A site: its mesh, hosts and processes. `skimesh up SITE.toml --host NAME` starts the
    processes of one host in dependency order (routers, store, simulator, agents, task agent),
    each ready before the next, and waits over the mesh for those of other hosts.

    Attributes:
        mesh: The mesh name (`--mesh`) of every process.
        scenario: The scenario: a name under `configs/scenarios` or a scenario file relative
            to the site file. The store loads its scene, the simulator its world, the agents
            their configs from it.
        hosts: The machines, by name (a one-host site may leave the table out: one host named
            `local`).
        routers: The Zenoh routers (at least one).
        store: The world-model store.
        sim: The simulator (leave out on real hardware).
        agents: The skill-agent processes.
        task_agent: The task agent (leave out for a site without one).
        monitor: A monitor (`skimesh monitor`).
        eventlog: The site event log (`skimesh eventlog`).
        restart: The restart policy of every process.
        zenoh_config: A Zenoh JSON5 file for every process but the routers (`--config`),
            relative to the site file (not with `security` on: it makes each process's own).
        security: `auto`: when a router listens beyond loopback (`0.0.0.0`, a host's
            address), the site runs on TLS only, with mutual TLS, one certificate per
            component and a least-privilege access-control list, made by `skimesh up`; on
            loopback it stays an open mesh. `tls`: always so. `none`: an open mesh (a trusted,
            isolated network only).
        credentials: The folder of the site's CA, certificates and Zenoh configs when
            `security` is on, relative to the site file (default: `<site file name>-credentials`
            beside it). Made if missing; copy it to every host of the site.
        ready_timeout (s): How long a process of this host may take to become ready.
        remote_timeout (s): How long to wait for a component of another host over the mesh.
        stop_grace (s): After SIGTERM, how long a process may take to stop before SIGKILL.
        state_dir: Each host's state directory (logs, status file, lock, the store's data;
            `~` expands, `{host}` becomes the host's name; `--state-dir` wins). Default:
            `$XDG_STATE_HOME/skimesh/sites/<site file name>-<host>` (`~/.local/state/...`).
    """

    mesh: str = "default"
    scenario: str = ""
    hosts: dict[str, Host] = {}
    routers: Annotated[list[Router], Meta(min_length=1)]
    store: Store | None = None
    sim: Sim | None = None
    agents: list[Agents] = []
    task_agent: TaskAgent | None = None
    monitor: Monitor | None = None
    eventlog: EventLog | None = None
    restart: Restart = Restart()
    zenoh_config: str = ""
    security: Literal["auto", "tls", "none"] = "auto"
    credentials: str = ""
    ready_timeout: Seconds = 120.0
    remote_timeout: Seconds = 300.0
    stop_grace: Seconds = 10.0
    state_dir: str = ""
