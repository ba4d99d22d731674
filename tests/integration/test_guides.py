"""Every guide's commands run as written (``tests/integration/guides.py`` runs them; the
convention is in ``docs/guides/README.md``): a guide cannot rot unnoticed.

The classification test is fast; running a guide starts its own router on a free port, the
world model, agents and the task agent as the guide says (simulated outcomes or ``--fast``
physics), and ends every process it started by its PID."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from meshlink.testing import free_port
from scenario import parse_scenario
from skill_agent.runtime import parse_config
from task_agent.taskfile import load_task_file

from .guides import GUIDES, Block, blocks, guide_files, run_guide, unclassified


def test_every_block_of_every_guide_is_run_or_skipped_with_a_reason() -> None:
    problems = [p for path in guide_files() for p in unclassified(path)]
    assert not problems, "\n".join(problems)


def test_the_guides_index_lists_every_guide() -> None:
    index = (GUIDES / "README.md").read_text(encoding="utf-8")
    missing = [p.name for p in guide_files() if f"({p.name})" not in index]
    assert not missing, f"docs/guides/README.md does not list {missing}"


LOADERS: dict[str, Callable[..., object]] = {
    "scenario": parse_scenario,
    "agent": parse_config,
    "task": load_task_file,
}
CONFIGS = [b for path in guide_files() for b in blocks(path) if b.directives.loads]


@pytest.mark.parametrize("block", CONFIGS, ids=[b.where for b in CONFIGS])
def test_the_guides_config_files_load(block: Block) -> None:
    """A block marked ``<!-- guide: loads as FORMAT -->`` is a whole file of that format."""
    assert block.info == "toml", f"{block.where}: only a toml block can load as a config"
    LOADERS[block.directives.loads](block.text, source=block.where)


RUNNABLE = [
    path
    for path in guide_files()
    if any(b.runnable and not b.directives.skip for b in blocks(path))
]


@pytest.mark.slow
@pytest.mark.zenoh
@pytest.mark.timeout(900)
@pytest.mark.parametrize("guide", RUNNABLE, ids=[p.name for p in RUNNABLE])
def test_the_guide_runs_as_written(guide: Path, tmp_path: Path) -> None:
    ran = list(run_guide(guide, free_port(), tmp_path))
    expected = [b for b in blocks(guide) if b.runnable and not b.directives.skip]
    assert [b.line for b in ran] == [b.line for b in expected]
