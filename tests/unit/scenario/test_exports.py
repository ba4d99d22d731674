"""Every name in an ``__all__`` of the scenario package exists, once."""

from __future__ import annotations

import importlib

import pytest

MODULES = [
    "scenario",
    "scenario.wm",
]


@pytest.mark.parametrize("module_name", MODULES)
def test_all_names_exist(module_name: str) -> None:
    module = importlib.import_module(module_name)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == []
    assert sorted(module.__all__) == sorted(set(module.__all__))
