"""Every name in an ``__all__`` of the device layer exists (anyio's test_all_attributes idea)."""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

MODULES = [
    "device_drivers",
    "device_drivers.protocol",
    "device_drivers.remote",
]


@pytest.mark.parametrize("module_name", MODULES)
def test_all_names_exist(module_name: str) -> None:
    module = importlib.import_module(module_name)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == []
    assert sorted(module.__all__) == sorted(set(module.__all__))


def test_package_import_is_pure() -> None:
    """The package root re-exports only the pure core: importing it pulls in no MuJoCo/placo."""
    code = "import device_drivers, sys; print('placo' in sys.modules, 'mujoco' in sys.modules)"
    root = Path(__file__).resolve().parents[3]
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=root
    )
    assert out.stdout.split() == ["False", "False"]
