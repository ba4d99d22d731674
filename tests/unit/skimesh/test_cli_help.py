"""The command line explains itself: every option and argument of every ``skimesh``
command and sub-command has a help text (parsed only, no Zenoh session)."""

from __future__ import annotations

import argparse
from collections.abc import Iterator

import pytest

from skimesh.cli import build_parser


def walk(
    parser: argparse.ArgumentParser, name: str
) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """Every (sub-)command under ``parser``, with its full name."""
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, child in action.choices.items():
                yield from walk(child, f"{name} {sub}")


COMMANDS = dict(walk(build_parser(), "skimesh"))


def test_the_walk_finds_the_nested_commands() -> None:
    for name in ("skimesh task submit", "skimesh wm check", "skimesh operator", "skimesh demo"):
        assert name in COMMANDS


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_option_has_a_help_text(command: str) -> None:
    parser = COMMANDS[command]
    bare = [
        "/".join(action.option_strings) or action.dest
        for action in parser._actions
        if not isinstance(action, argparse._HelpAction | argparse._SubParsersAction)
        and not (action.help or "").strip()
    ]
    assert not bare, f"{command}: no help for {bare}"
