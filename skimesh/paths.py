"""Where the packaged data lives: ``configs/`` at the repository root (editable install) or
inside the package (wheel)."""

from __future__ import annotations

from pathlib import Path

import scenario
from scenario import Scenario

__all__ = ["config_path", "configs_dir", "known_scenarios", "read_scenario"]

_HERE = Path(__file__).resolve().parent


def configs_dir() -> Path:
    for candidate in (_HERE / "configs", _HERE.parent / "configs"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"skimesh configs not found next to {_HERE}")


def config_path(*parts: str) -> Path:
    path = configs_dir().joinpath(*parts)
    if not path.exists():
        raise FileNotFoundError(f"no {'/'.join(parts)} in {configs_dir()}")
    return path


def known_scenarios() -> list[str]:
    """The names of the scenarios shipped in ``configs/scenarios``."""
    return scenario.known_scenarios(configs_dir() / "scenarios")


def read_scenario(name_or_path: str) -> Scenario:
    """A scenario by file, else by the name of a shipped one. Raises ScenarioError (an unknown
    name: the message lists the known ones)."""
    return scenario.read_scenario(name_or_path, configs_dir() / "scenarios")
