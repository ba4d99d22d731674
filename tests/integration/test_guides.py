"""Every guide's commands run as written (``tests/integration/guides.py`` runs them; the
convention is in ``docs/guides/README.md``): a guide cannot rot unnoticed.

The classification test is fast; running a guide starts its own router on a free port, the
world model, agents and the task agent as the guide says (simulated outcomes or ``--fast``
physics), and ends every process it started by its PID."""

from __future__ import annotations

from pathlib import Path

import pytest

from meshlink.testing import free_port

from .guides import GUIDES, blocks, guide_files, run_guide, unclassified


def test_every_block_of_every_guide_is_run_or_skipped_with_a_reason() -> None:
    problems = [p for path in guide_files() for p in unclassified(path)]
    assert not problems, "\n".join(problems)


def test_the_guides_index_lists_every_guide() -> None:
    index = (GUIDES / "README.md").read_text(encoding="utf-8")
    missing = [p.name for p in guide_files() if f"({p.name})" not in index]
    assert not missing, f"docs/guides/README.md does not list {missing}"


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
