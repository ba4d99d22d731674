"""Integration-test fixtures: a fresh mesh name per test, so tests sharing a router never see
each other's keys."""

from __future__ import annotations

import uuid

import pytest


@pytest.fixture
def mesh_name() -> str:
    return f"it-{uuid.uuid4().hex[:10]}"
