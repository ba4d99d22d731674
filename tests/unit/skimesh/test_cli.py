"""The ``skimesh`` command line, parsed only (no Zenoh session): the same Zenoh flags on every
long-running command, and clear usage errors."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from meshlink import MeshConfig, mesh_config_from_args
from skimesh.cli import build_parser, describe_error, hoist_connection_options, main

ROUTER_A, ROUTER_B = "tcp/10.0.0.1:7447", "tcp/10.0.0.2:7447"
ZENOH_FLAGS = ["--connect", ROUTER_A, "--connect", ROUTER_B, "--config", "site.json5"]

#: Every long-running command, with the arguments it needs besides the Zenoh flags.
SERVICES = {
    "router": [],
    "wm": ["--data", "wm-data"],
    "sim": ["--scenario", "kitting"],
    "agent": ["--scenario", "kitting", "--robot", "r1"],
    "task-agent": [],
    "operator": [],
}


def parse(*argv: str) -> argparse.Namespace:
    return build_parser().parse_args(argv)


@pytest.mark.parametrize("command", sorted(SERVICES))
def test_every_service_takes_repeated_connect_and_a_zenoh_config(command: str) -> None:
    args = parse(command, *SERVICES[command], *ZENOH_FLAGS)
    assert args.connect == [ROUTER_A, ROUTER_B]
    assert args.zenoh_config == "site.json5"
    assert args.listen is None


@pytest.mark.parametrize("command", ["wm", "sim", "agent", "task-agent", "operator"])
def test_the_zenoh_flags_make_the_same_mesh_config_everywhere(command: str) -> None:
    args = parse(command, *SERVICES[command], *ZENOH_FLAGS, "--mesh", "lab")
    assert mesh_config_from_args(args) == MeshConfig(
        connect=(ROUTER_A, ROUTER_B), config_file="site.json5", mesh="lab"
    )


def test_the_router_links_to_other_routers_and_has_no_mesh_or_mode(
    capsys: pytest.CaptureFixture[str],
) -> None:
    args = parse("router", "--listen", "tcp/0.0.0.0:7447", "--connect", ROUTER_A)
    assert (args.listen, args.connect) == (["tcp/0.0.0.0:7447"], [ROUTER_A])
    with pytest.raises(SystemExit) as exit_info:
        parse("router", "--mode", "peer")
    assert exit_info.value.code == 2
    assert "unrecognized arguments: --mode" in capsys.readouterr().err


def test_the_agent_takes_its_own_toml_as_agent_config() -> None:
    args = parse("agent", "--agent-config", "r1.toml", "--config", "client.json5")
    assert (args.agent_config, args.zenoh_config) == (["r1.toml"], "client.json5")
    assert args.scenario is None


@pytest.mark.parametrize("toml", ["r1.toml", "configs/agents/kitting/R2.TOML"])
def test_an_agent_toml_given_to_config_points_to_agent_config(
    toml: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["agent", "--config", toml, "--connect", ROUTER_A])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert f"--agent-config {toml}" in err
    assert "Zenoh JSON5" in err
    assert "Traceback" not in err


def test_the_agent_needs_a_scenario_or_an_agent_config(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["agent", "--config", "client.json5"])
    assert exit_info.value.code == 2
    assert "one of the arguments --scenario --agent-config is required" in capsys.readouterr().err


def test_an_error_without_a_message_is_still_described() -> None:
    """A bare ``TimeoutError`` (``anyio.fail_after``) is printed as words, never as nothing."""
    assert "timed out" in describe_error(TimeoutError())
    assert describe_error(KeyError()) == "KeyError"
    assert describe_error(TimeoutError("store: no answer in 5 s")) == "store: no answer in 5 s"


def test_the_operator_says_where_they_see_things() -> None:
    """``skimesh operator --answer 3 success --seen MealBox-1=0.77,-0.4,0.78`` (repeatable,
    with an optional heading); anything else is a usage error that shows the form."""
    args = parse(
        "operator", "--answer", "3", "success", "--seen", "MealBox-1=0.77,-0.4,0.78",
        "--seen", "Tray-1=0.8,0.1,0.76,1.57",
    )  # fmt: skip
    first, second = args.seen
    assert (first.element, first.position, first.yaw) == ("MealBox-1", (0.77, -0.4, 0.78), None)
    assert (second.element, second.yaw) == ("Tray-1", 1.57)
    for bad in ("MealBox-1", "MealBox-1=1,2", "=1,2,3", "MealBox-1=a,b,c"):
        with pytest.raises(SystemExit):
            parse("operator", "--answer", "3", "success", "--seen", bad)


def test_demo_ontology_files_join_the_scenarios(tmp_path: Path) -> None:
    from skimesh.commands.demo import _setup

    extra = tmp_path / "extra.ttl"
    extra.write_text("@prefix skm: <https://skimesh.dev/ontology#> .\n")
    setup = _setup(parse("demo", "--ontology", str(extra)), tmp_path)
    assert setup.scenario.ontology[-1] == str(extra.resolve())
    with pytest.raises(ValueError, match="no file"):
        _setup(parse("demo", "--ontology", str(tmp_path / "missing.ttl")), tmp_path)


def test_wm_connection_options_go_before_or_after_the_sub_command() -> None:
    before = parse("wm", "--connect", ROUTER_A, "--mesh", "m1", "--timeout", "2", "tree")
    after = parse("wm", "tree", "--connect", ROUTER_A, "--mesh", "m1", "--timeout", "2")
    for args in (before, after):
        assert mesh_config_from_args(args) == MeshConfig(connect=(ROUTER_A,), mesh="m1")
        assert args.timeout == 2.0
    plain = parse("wm", "teach", "x.ttl")
    assert plain.mesh == "default" and plain.timeout == 5.0 and plain.connect is None


@pytest.mark.parametrize(
    "argv",
    [
        "task --connect {r} --mesh m1 --timeout 2 list",
        "task list --connect {r} --mesh m1 --timeout 2",
        "task --connect {r} list --mesh m1 --timeout 2",
        "--connect {r} --mesh m1 task --timeout 2 list",
        "-v --connect={r} --mesh=m1 --timeout 2 task list",
    ],
)
def test_task_connection_options_go_anywhere(argv: str) -> None:
    """Before the command, between ``task`` and its command, after it: the same options."""
    words = hoist_connection_options(argv.format(r=ROUTER_A).split())
    args = build_parser(words).parse_args(words)
    assert args.task_command == "list"
    assert mesh_config_from_args(args) == MeshConfig(connect=(ROUTER_A,), mesh="m1")
    assert args.timeout == 2.0 and args.json is False
    plain = parse("task", "list")
    assert plain.mesh == "default" and plain.timeout == 5.0 and plain.connect is None


def test_connection_options_before_a_command_reach_it() -> None:
    assert hoist_connection_options(["--debug", "--connect", "E", "agents", "r1"]) == [
        "--debug", "agents", "--connect", "E", "r1",
    ]  # fmt: skip
    args = build_parser(["agents"]).parse_args(
        hoist_connection_options(["--mesh", "m2", "agents", "--timeout", "3"])
    )
    assert args.mesh == "m2" and args.timeout == 3.0
    unchanged = ["-v", "agents", "--connect", "E"]
    assert hoist_connection_options(unchanged) == unchanged


def test_a_command_without_connection_options_refuses_them(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["--mesh", "m1", "demo"])
    assert stop.value.code == 2
    assert "unrecognized arguments: --mesh m1" in capsys.readouterr().err


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        parse("--version")
    assert stop.value.code == 0
    assert capsys.readouterr().out.startswith("skimesh ")


#: Loaded only by the commands that need them: the planners (over a second to import), the
#: simulator, the viewer and rdflib (the ontology, loaded with the first world-model replica).
HEAVY = ("unified_planning", "mujoco", "placo", "rerun", "rdflib")
NOWHERE = "tcp/127.0.0.1:9"  # nothing listens: a client command fails at once, exit 3

#: The light commands, run to their end (no router answers: they stop where they would connect).
LIGHT = {
    "help": ["--help"],
    "version": ["--version"],
    "agents help": ["agents", "--help"],
    "agents": ["agents", "--connect", NOWHERE, "--timeout", "0.5"],
    "skills": ["skills", "--connect", NOWHERE, "--timeout", "0.5"],
    "wm get": ["wm", "get", "Gear-1", "--connect", NOWHERE, "--timeout", "0.5"],
    "task status": ["task", "status", "t-1", "--connect", NOWHERE, "--timeout", "0.5"],
}


@pytest.mark.parametrize("name", sorted(LIGHT))
def test_light_commands_load_no_planner_simulator_viewer_or_rdflib(name: str) -> None:
    """``skimesh --help``, ``--version`` and the light commands import none of the heavy
    packages (a fresh interpreter, the command run through ``main``)."""
    import subprocess
    import sys

    probe = (
        "import sys\n"
        "from skimesh.cli import main\n"
        "try:\n"
        f"    code = main({LIGHT[name]!r})\n"
        "except SystemExit as stop:\n"
        "    code = stop.code\n"
        f"print(code, [m for m in {HEAVY!r} if m in sys.modules])"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=60, check=True
    )
    code, loaded = done.stdout.strip().splitlines()[-1].split(" ", 1)
    assert loaded == "[]", done.stdout + done.stderr
    assert code == ("0" if "help" in name or name == "version" else "3"), done.stderr


def test_the_list_of_commands_is_the_modules() -> None:
    """``skimesh --help`` lists the commands from ``cli.COMMANDS`` without importing their
    modules: every command a module adds is there, with the module's help, in its order."""
    import argparse

    from skimesh.cli import COMMANDS

    def listed(parser: argparse.ArgumentParser) -> dict[str, object]:
        (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        return {c.dest: c.help for c in sub._choices_actions}

    full = listed(build_parser())
    assert full == {name: text for name, (_, text) in COMMANDS.items()}
    assert list(full) == list(COMMANDS)
    assert listed(build_parser(["--help"])) == full
    for name, (module, _) in COMMANDS.items():
        args = build_parser([name, "--help"])
        assert listed(args) == full, f"{name} ({module})"
