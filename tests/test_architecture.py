"""The architecture, checked from the source: layers import downwards only, the pure cores do
not touch the network or the simulator, and every package's public API exists.

    skimesh (CLI, demo) -> task_agent -> skill_agent -> wm_store, device_drivers -> meshlink
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ["meshlink", "wm_store", "device_drivers", "skill_agent", "task_agent", "skimesh"]

ALLOWED: dict[str, set[str]] = {
    "meshlink": set(),
    "wm_store": {"meshlink"},
    "device_drivers": {"meshlink"},
    "skill_agent": {"meshlink", "wm_store", "device_drivers"},
    "task_agent": {"meshlink", "wm_store", "device_drivers", "skill_agent"},
    "skimesh": set(PACKAGES),
}

# Modules allowed to talk to the network (import zenoh or meshlink): the adapters.
NETWORK_ADAPTERS = {
    "wm_store/server.py",
    "wm_store/presence.py",
    "wm_store/transport.py",
}
NETWORK = {"zenoh", "meshlink"}


def imports_of(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module.split(".")[0])
    return found


def modules(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("package", PACKAGES)
def test_layers_import_downwards_only(package: str) -> None:
    forbidden = set(PACKAGES) - ALLOWED[package] - {package}
    for path in modules(package):
        bad = imports_of(path) & forbidden
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)} (layering)"


def test_world_model_core_is_transport_free() -> None:
    for path in modules("wm_store"):
        rel = str(path.relative_to(ROOT))
        if rel in NETWORK_ADAPTERS:
            continue
        bad = imports_of(path) & NETWORK
        assert not bad, f"{rel} is core but imports {sorted(bad)}; only adapters may"


def test_only_meshlink_talks_to_zenoh() -> None:
    """Every thread/async crossing lives in meshlink; the other packages use its API."""
    for package in PACKAGES:
        if package == "meshlink":
            continue
        for path in modules(package):
            assert "zenoh" not in imports_of(path), f"{path.relative_to(ROOT)} imports zenoh"


@pytest.mark.parametrize("package", PACKAGES)
def test_public_api_exists(package: str) -> None:
    module = importlib.import_module(package)
    exported = getattr(module, "__all__", None)
    assert isinstance(exported, list)
    missing = [name for name in exported if not hasattr(module, name)]
    assert not missing, f"{package}.__all__ names missing attributes: {missing}"
    assert len(set(exported)) == len(exported)
