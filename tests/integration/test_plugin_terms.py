"""A skill plug-in in a package of its own, with its own ontology terms, planned and run through
the task layer, every component in its own process, none given an ontology file.

The plug-in (``docs/examples/inspection``: the ``inspect`` skill and ``inspection.ttl``, which
declares ``inspected`` and ``inspectionScore``) is loaded by one agent. The agent teaches the
terms to the store before it checks its skills; the task agent, started before the agent, and
CLI clients take them from the store: ``task verify`` and ``task submit`` of a goal on
``inspected`` succeed, and the world model holds the result.
"""

from __future__ import annotations

import os
import subprocess
import sys
import uuid
from collections.abc import Iterator
from pathlib import Path

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from wm_store import WmClient, ZenohTransport

from .procs import ROOT, Child, start_store

PLUGIN = ROOT / "docs" / "examples" / "inspection"

AGENT = """\
name = "inspector"

[robot]
type = "MobileManipulator"
label = "inspector"

[skills]
paths = ["skimesh_inspection:Inspect"]
"""


TASK = """\
name = "inspect by hand"

[root]
block = "call"
agent = "inspector"
skill = "inspect"
params = {{ part = "{gear}" }}
"""


class Site:
    def __init__(self, endpoint: str, folder: Path) -> None:
        self.endpoint, self.mesh, self.folder = endpoint, f"it-{uuid.uuid4().hex[:10]}", folder
        # The plug-in is a separate package: importable, not part of the project.
        self.env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(PLUGIN), str(ROOT)]))

    def flags(self) -> list[str]:
        return ["--connect", self.endpoint, "--mesh", self.mesh]

    def skimesh(self, *args: str) -> subprocess.CompletedProcess[str]:
        # `wm` takes the connection options before its sub-command
        wm = args[0] == "wm"
        args = ("wm", *self.flags(), *args[1:]) if wm else (*args, *self.flags())
        return subprocess.run(
            [sys.executable, "-m", "skimesh", *args],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )


@pytest.fixture
def site(router_endpoint: str, tmp_path: Path) -> Iterator[Site]:
    s = Site(router_endpoint, tmp_path)
    store = start_store(s.endpoint, s.mesh, tmp_path / "wm")
    children: list[Child] = []
    try:
        task_agent = Child(["-m", "skimesh", "task-agent", *s.flags()], name="task agent")
        children.append(task_agent)
        task_agent.wait_stderr("task agent ready")
        config = tmp_path / "inspector.toml"
        config.write_text(AGENT)
        agent = Child(
            ["-m", "skimesh", "agent", "--agent-config", str(config), *s.flags()],
            name="agent",
            env=s.env,
        )
        children.append(agent)
        agent.wait_stderr("agent inspector ready", timeout=60)
        yield s
    finally:
        for child in reversed(children):
            child.stop()
        store.stop()


async def _add_gear(site: Site) -> str:
    config = MeshConfig(connect=(site.endpoint,), mesh=site.mesh)
    async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
        assert wm.ontology.data_property("inspected").kinds == {"bool"}, "taught by the agent"
        return await wm.add_element("Gear", "gear-a")


async def _inspected(site: Site, gear: str) -> dict[str, object]:
    config = MeshConfig(connect=(site.endpoint,), mesh=site.mesh)
    async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
        return dict(wm.get_element(gear).properties)


@pytest.mark.slow
def test_a_plugin_skills_own_terms_are_planned_and_run(site: Site) -> None:
    gear = anyio.run(_add_gear, site)
    goal = f"inspected({gear}) = true"

    plan = site.skimesh("task", "plan", "--goal", goal)
    assert plan.returncode == 0 and "inspect" in plan.stdout, plan.stdout + plan.stderr
    task = site.folder / "inspect.toml"
    task.write_text(TASK.format(gear=gear))
    verify = site.skimesh("task", "verify", str(task))
    assert verify.returncode == 0, verify.stdout + verify.stderr

    submit = site.skimesh("task", "submit", "--goal", goal)
    assert submit.returncode == 0, submit.stdout + submit.stderr
    assert f"inspect(part=gear-a ({gear}))" in submit.stdout, "the plan names it label (id)"

    properties = anyio.run(_inspected, site, gear)
    assert properties["inspected"] is True and properties["inspectionScore"] == 0.93

    # A plain CLI client (no --ontology) reads the plug-in's property and its terms.
    shown = site.skimesh("wm", "query", "Gear", "--where", "inspected=true")
    assert shown.returncode == 0 and gear in shown.stdout, shown.stdout + shown.stderr
    taught = site.skimesh("wm", "ontology", "--taught")
    assert "inspector: inspection.ttl" in taught.stdout and "skm:inspected" in taught.stdout
