"""The task layer's command line explains itself: every option and argument of ``skimesh
task-agent``, ``skimesh task ...`` and ``skimesh operator`` has a help text (parsed only, no
Zenoh session)."""

from __future__ import annotations

import argparse

import pytest

from skimesh.cli import build_parser

TASK_COMMANDS = ["submit", "plan", "status", "list", "abort", "watch", "verify"]


def subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def commands() -> dict[str, argparse.ArgumentParser]:
    top = subparsers(build_parser())
    found = {"task-agent": top["task-agent"], "operator": top["operator"]}
    task = subparsers(top["task"])
    found.update((f"task {name}", task[name]) for name in TASK_COMMANDS)
    return found


@pytest.mark.parametrize("command", sorted(commands()))
def test_every_option_has_a_help_text(command: str) -> None:
    parser = commands()[command]
    bare = [
        "/".join(action.option_strings) or action.dest
        for action in parser._actions
        if not isinstance(action, argparse._HelpAction) and not (action.help or "").strip()
    ]
    assert not bare, f"skimesh {command}: no help for {bare}"
