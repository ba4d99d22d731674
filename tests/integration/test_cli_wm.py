"""The ``skimesh`` command as a user runs it: a store process, then ``wm`` client commands."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from .procs import ROOT, start_store

pytestmark = [pytest.mark.zenoh, pytest.mark.slow]

SCENE = ROOT / "configs" / "scenes" / "sample.ttl"


def skimesh(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "skimesh", *args],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )


def test_wm_client_commands(router_endpoint: str, mesh_name: str, tmp_path: Path) -> None:
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    common = ["--connect", router_endpoint, "--mesh", mesh_name]
    try:
        imported = skimesh("wm", *common, "import", str(SCENE))
        assert imported.returncode == 0, imported.stderr
        assert "imported" in imported.stdout

        tree = skimesh("wm", *common, "tree")
        assert tree.returncode == 0, tree.stderr
        assert "contain → Gear-1" in tree.stdout

        listed = skimesh("wm", *common, "ls", "Part", "--json")
        parts = json.loads(listed.stdout)
        assert sorted(p["id"] for p in parts) == ["Gear-1", "Gear-2", "Shaft-1", "Shaft-2"]

        missing = skimesh("wm", *common, "query", "Gear", "--label", "nothing-like-this")
        assert missing.returncode == 1

        typo = skimesh("wm", *common, "ls", "Gaer")
        assert typo.returncode != 0
        assert "Gear" in typo.stderr, "the error names the closest class"

        exported = skimesh("wm", *common, "export", str(tmp_path / "scene.ttl"))
        assert exported.returncode == 0, exported.stderr
        assert "skm:Gear" in (tmp_path / "scene.ttl").read_text()

        info = json.loads(skimesh("wm", *common, "info").stdout)
        assert info["elements"] == len(parts) + 10
        assert info["durability"] == "group"
    finally:
        assert store.stop() == 0, store.log()


def test_no_store_fails_fast_with_advice(router_endpoint: str, mesh_name: str) -> None:
    result = skimesh(
        "wm", "--connect", router_endpoint, "--mesh", mesh_name, "--timeout", "1", "ls"
    )
    assert result.returncode != 0
    assert "skimesh wm" in result.stderr
