"""``skimesh wm watch`` and ``wm history`` in words: an update says what it changed, against
the state before it (the watch is seeded from the replica; history learns as it goes)."""

from __future__ import annotations

import argparse

import anyio
import pytest

from skimesh.commands._edit import _history, _watch
from tests.unit.wm_store.stores import memory_client
from wm_store.protocol import Pose, Position

pytestmark = pytest.mark.anyio


async def test_watch_words_each_change_against_the_state_before_it(
    capsys: pytest.CaptureFixture[str],
) -> None:
    async with memory_client() as wm:
        gear = await wm.add_element("Gear", label="gear-z", properties={"mass": 0.12})
        async with anyio.create_task_group() as tg:
            tg.start_soon(_watch, argparse.Namespace(json=False), wm)
            await anyio.wait_all_tasks_blocked()  # following
            # the watch words each change against its own copy, not the replica (ahead of it)
            await wm.update_element(gear, {"mass": 0.2}, label="gear-y")
            await wm.update_element(gear, {"pose": Pose(Position(0.4, 0.1, 0.75))})
            await wm.remove_element(gear)
            await anyio.wait_all_tasks_blocked()
            tg.cancel_scope.cancel()
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(": ", 1)[1] for line in lines] == [
        f'gear-y ({gear}) label "gear-z" -> "gear-y", mass 0.12 -> 0.2',
        f"gear-y ({gear}) pose unset -> (0.400, 0.100, 0.750)",
        f"removed gear-y ({gear})",
    ]


async def test_history_learns_the_elements_as_it_goes(capsys: pytest.CaptureFixture[str]) -> None:
    async with memory_client() as wm:
        box = await wm.add_element("Box", label="bin")
        await wm.update_element(box, {"mass": 1.5})
        await wm.update_element(box, {"mass": 2.0})
        await _history(argparse.Namespace(json=False, since=0), wm)
        from_start = capsys.readouterr().out.splitlines()
        await _history(argparse.Namespace(json=False, since=2), wm)
        late = capsys.readouterr().out.splitlines()
    assert [line.split(": ", 1)[1] for line in from_start] == [
        f"+bin ({box}) [Box]",  # revision 1 follows the empty store: new
        f"bin ({box}) mass unset -> 1.5",
        f"bin ({box}) mass 1.5 -> 2",
    ]
    assert [line.split(": ", 1)[1] for line in late] == [f"put bin ({box}) [Box]"]
