"""Several agents in one process load the same plug-ins from their own threads at once: none
may see a module another thread is still importing (which showed as ``module ... has no
'Place'``). The plug-in's body waits, mid-import, until every other loader has started."""

from __future__ import annotations

import sys
import textwrap
import threading
import types
from pathlib import Path

import pytest

from skill_agent.runtime import SkillRegistry
from wm_store.ontology import Ontology

BODY = textwrap.dedent(
    """
    import skimesh_test_gate as gate
    gate.entered.set()
    gate.release.wait(10)  # the other loaders start while this module is half imported

    from skill_agent import Skill
    from skill_agent.protocol import SkillDescription

    class Slow(Skill):
        description = SkillDescription(name="slow", doc="Loads slowly.")
    """
)


@pytest.mark.parametrize("how", ["dotted", "file"])
def test_concurrent_loads_never_see_a_half_imported_plugin(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, how: str
) -> None:
    name = f"slow_plugin_{how}"
    (tmp_path / f"{name}.py").write_text(BODY)
    monkeypatch.syspath_prepend(str(tmp_path))
    gate = types.ModuleType("skimesh_test_gate")
    gate.entered, gate.release = threading.Event(), threading.Event()  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "skimesh_test_gate", gate)
    ref = f"{name}:Slow" if how == "dotted" else f"{tmp_path / name}.py:Slow"
    results: list[object] = []

    def load() -> None:
        try:
            results.append(sorted(SkillRegistry(Ontology.default(), paths=[ref]).load()))
        except Exception as exc:  # recorded, asserted below
            results.append(exc)

    first = threading.Thread(target=load)
    first.start()
    entered: threading.Event = gate.entered
    assert entered.wait(10), "the first loader reached the plug-in's body"
    others = [threading.Thread(target=load) for _ in range(6)]
    for thread in others:
        thread.start()
    gate.release.set()
    for thread in [first, *others]:
        thread.join(20)
    for module in [n for n in sys.modules if "slow_plugin" in n]:
        monkeypatch.delitem(sys.modules, module)
    assert results == [["slow"]] * 7, results
