"""Every name in an ``__all__`` of the simulator exists, once (anyio's test_all_attributes idea)."""

from __future__ import annotations

import importlib

import pytest

MODULES = [
    "mujoco_sim",
    "mujoco_sim.control",
    "mujoco_sim.ik",
    "mujoco_sim.models",
    "mujoco_sim.motion",
    "mujoco_sim.physics",
    "mujoco_sim.placo_ik",
    "mujoco_sim.recording",
]


@pytest.mark.parametrize("module_name", MODULES)
def test_all_names_exist(module_name: str) -> None:
    module = importlib.import_module(module_name)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == []
    assert sorted(module.__all__) == sorted(set(module.__all__))
