"""The site file: decoding, checks with clear errors, the plan's order and probes, the
restart policy, the state directory's lock."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from skimesh.site import (
    Restart,
    SiteError,
    StateDir,
    default_state_dir,
    describe_exit,
    ensure_credentials,
    load_site,
    make_plan,
    restart_delay,
)

ROOT = Path(__file__).resolve().parents[3]
SITES = sorted((ROOT / "configs" / "sites").glob("*.toml"))


def _site(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "site.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _plan(tmp_path: Path, text: str, host: str | None = None):  # type: ignore[no-untyped-def]
    path = _site(tmp_path, text)
    return make_plan(load_site(path), path, host)


TWO_HOSTS = """
mesh = "m"
scenario = "kitting"
[hosts.server]
address = "10.0.0.1"
[hosts.robots]
[[routers]]
host = "server"
listen = ["tcp/0.0.0.0:7447"]
[store]
host = "server"
[sim]
host = "server"
fast = true
[[agents]]
host = "robots"
robots = ["r1", "r2"]
[task_agent]
host = "server"
"""


@pytest.mark.parametrize("path", SITES, ids=[p.name for p in SITES])
def test_every_shipped_site_plans_for_each_of_its_hosts(path: Path) -> None:
    site = load_site(path)
    hosts: list[str | None] = [*sorted(site.hosts)] or [None]
    for host in hosts:
        plan = make_plan(site, path, host)
        kinds = [c.kind for c in plan.components]
        assert kinds[0] == "router"
        order = ["router", "store", "sim", "agents", "task-agent", "eventlog", "monitor"]
        assert kinds == sorted(kinds, key=order.index)


def test_components_start_in_dependency_order_with_their_probes(tmp_path: Path) -> None:
    plan = _plan(tmp_path, TWO_HOSTS, "robots")
    assert [(c.name, c.host, c.ready) for c in plan.components] == [
        ("router", "server", ("tcp", "10.0.0.1", "7447")),
        ("store", "server", ("store",)),
        ("sim", "server", ("devices",)),
        ("agents-r1-r2", "robots", ("agents", "r1", "r2")),
        ("task-agent", "server", ("tasks",)),
    ]
    assert [c.name for c in plan.local()] == ["agents-r1-r2"]
    # robots reach the server's router by its address; the server by loopback; on TLS, since
    # the router listens beyond loopback (security "auto")
    assert plan.connect == ("tls/10.0.0.1:7447",)
    agents = plan.components[3].argv
    assert agents[:3] == ("agent", "--connect", "tls/10.0.0.1:7447")
    assert plan.security is not None
    assert agents[agents.index("--config") + 1] == str(plan.security.folder / "agents-r1-r2.json5")
    assert plan.components[3].serves == (("r1", "r1"), ("r2", "r2"))
    assert agents[agents.index("--robot") : agents.index("--robot") + 2] == ("--robot", "r1")
    assert "--fast" in plan.components[2].argv
    server = _plan(tmp_path, TWO_HOSTS, "server")
    assert server.connect == ("tls/127.0.0.1:7447",)
    assert server.components[0].ready == ("tcp", "127.0.0.1", "7447")


def test_the_only_host_is_the_default_and_hosts_may_be_left_out(tmp_path: Path) -> None:
    plan = _plan(tmp_path, '[[routers]]\nlisten = ["tcp/127.0.0.1:7000"]\n[store]\n')
    assert plan.host == "local"
    assert [c.host for c in plan.components] == ["local", "local"]
    assert "--data" in plan.components[1].argv


@pytest.mark.parametrize(
    ("text", "host", "message"),
    [
        (TWO_HOSTS, "nope", "no host 'nope' in the site; its hosts: robots, server"),
        (TWO_HOSTS.replace('host = "robots"\n', ""), "server", "an agents process is on no host"),
        (TWO_HOSTS.replace('host = "robots"\n', 'host = "r9"\n'), "server", "unknown host 'r9'"),
        (TWO_HOSTS.replace('"kitting"', '"kittin"'), "server", "scenario 'kittin'"),
        (TWO_HOSTS.replace('"r1", "r2"', '"r1", "r7"'), "server", "no agent for r7"),
        (TWO_HOSTS.replace('address = "10.0.0.1"', ""), "robots", "an `address`"),
        (
            TWO_HOSTS + '[[routers]]\nhost = "server"\nlisten = ["tcp/10.0.0.1:7447"]\n',
            "server",
            "ports clash on host server: router-2 and router both listen on port 7447",
        ),
        (
            TWO_HOSTS + '[[agents]]\nhost = "server"\nrobots = ["r2"]\n',
            "server",
            "agent r2 is served twice",
        ),
        (TWO_HOSTS.replace('"tcp/0.0.0.0:7447"', '"7447"'), "server", "is not PROTOCOL"),
        (TWO_HOSTS + "[monitor]\n", "server", "the monitor is on no host"),
    ],
)
def test_bad_sites_are_refused_with_a_clear_message(
    tmp_path: Path, text: str, host: str, message: str
) -> None:
    with pytest.raises(SiteError, match=message.replace("(", r"\(").replace("`", ".")):
        _plan(tmp_path, text, host)


def test_an_unknown_key_names_its_path(tmp_path: Path) -> None:
    path = _site(tmp_path, '[[routers]]\nlisten = ["tcp/127.0.0.1:7000"]\n[store]\ndta = "x"\n')
    with pytest.raises(SiteError, match=r"\$\.store"):
        load_site(path)


def test_listen_replaces_the_only_routers_endpoints(tmp_path: Path) -> None:
    path = _site(tmp_path, '[[routers]]\nlisten = ["tcp/127.0.0.1:7000"]\n[store]\n')
    plan = make_plan(load_site(path), path, listen=["tcp/127.0.0.1:7123"])
    assert plan.connect == ("tcp/127.0.0.1:7123",)
    assert plan.components[0].argv == ("router", "--listen", "tcp/127.0.0.1:7123")


def test_the_monitor_records_the_sites_scenario(tmp_path: Path) -> None:
    text = 'scenario = "kitting"\n[[routers]]\nlisten = ["tcp/127.0.0.1:7000"]\n[monitor]\n'
    monitor = _plan(tmp_path, text).components[-1]
    assert monitor.kind == "monitor" and monitor.ready == ()
    assert monitor.argv[0] == "monitor" and "--rrd" in monitor.argv
    assert monitor.argv[monitor.argv.index("--scenario") + 1] == "kitting"


def test_restart_policy_backs_off_and_gives_up_after_max_restarts_in_the_window() -> None:
    policy = Restart(policy="on-failure", backoff=1.0, max_backoff=5.0, max_restarts=3, window=60)
    assert restart_delay(policy, 0, [], 100.0) is None  # a clean exit
    assert restart_delay(policy, -9, [], 100.0) == 1.0
    assert restart_delay(policy, 1, [90.0], 100.0) == 2.0
    assert restart_delay(policy, 1, [80.0, 90.0], 100.0) == 4.0
    assert restart_delay(policy, 1, [70.0, 80.0, 90.0], 100.0) is None  # 3 in the window
    assert restart_delay(policy, 1, [10.0, 20.0, 90.0], 100.0) == 2.0  # two left the window
    capped = Restart(backoff=4.0, max_backoff=5.0)
    assert restart_delay(capped, 1, [99.0], 100.0) == 5.0
    assert restart_delay(Restart(policy="always"), 0, [], 1.0) == 1.0
    assert restart_delay(Restart(policy="no"), 1, [], 1.0) is None
    assert describe_exit(-9) == "killed by SIGKILL"
    assert describe_exit(3) == "exit code 3"


def test_the_state_directory_comes_from_the_site_else_xdg(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path))
    site = Path("configs/sites/kitting.toml")
    assert default_state_dir(site, "server") == tmp_path / "skimesh/sites/kitting-server"
    chosen = default_state_dir(site, "r1", f"{tmp_path}/site/{{host}}")
    assert chosen == tmp_path / "site/r1"


def test_the_state_directory_lock_admits_one_supervisor(tmp_path: Path) -> None:
    first, second = StateDir(tmp_path / "s"), StateDir(tmp_path / "s")
    assert first.holder() is None
    first.acquire()
    try:
        assert second.holder() is not None
        with pytest.raises(SiteError, match="up already"):
            second.acquire()
    finally:
        first.release()
    assert second.holder() is None


def test_a_site_is_secure_off_loopback_and_open_on_it(tmp_path: Path) -> None:
    loopback = _plan(tmp_path, '[[routers]]\nlisten = ["tcp/127.0.0.1:7000"]\n[store]\n')
    assert loopback.security is None and loopback.probe_config is None
    assert "--config" not in loopback.components[1].argv
    open_site = _plan(tmp_path, 'security = "none"\n' + TWO_HOSTS, "robots")
    assert open_site.security is None and open_site.connect == ("tcp/10.0.0.1:7447",)
    forced = _plan(tmp_path, 'security = "tls"\n[[routers]]\nlisten = ["tcp/127.0.0.1:7000"]\n')
    assert forced.security is not None and forced.connect == ("tls/127.0.0.1:7000",)
    router = forced.components[0].argv
    assert router[router.index("--config") + 1] == str(forced.security.folder / "router.json5")
    assert forced.probe_config == str(forced.security.folder / "operator.json5")
    with pytest.raises(SiteError, match="`zenoh_config` and `security`"):
        _plan(tmp_path, 'zenoh_config = "z.json5"\n' + TWO_HOSTS, "robots")


def test_a_secure_sites_credentials_are_made_once_for_every_component(tmp_path: Path) -> None:
    plan = _plan(tmp_path, TWO_HOSTS + '[eventlog]\nhost = "server"\n', "server")
    assert plan.security is not None
    folder = ensure_credentials(plan)
    assert folder == plan.security.folder
    made = {p.name for p in folder.iterdir()}
    for name in ("store", "sim", "agents-r1-r2", "task-agent", "eventlog", "operator"):
        assert {f"{name}.pem", f"{name}-key.pem", f"{name}.json5"} <= made, name
    assert {"ca.pem", "router.pem", "router.json5"} <= made
    ca = (folder / "ca.pem").read_bytes()
    ensure_credentials(plan)  # again: the same CA
    assert (folder / "ca.pem").read_bytes() == ca
    router = (folder / "router.json5").read_text()
    assert (
        "agents-r1-r2" in json.loads(router)["access_control"]["subjects"][2]["cert_common_names"]
    )
