"""Simulated-outcome mode: probabilities, seeded draws, 200 runs within a binomial bound,
effects on success only, no skill code executed, composite children simulated."""

from __future__ import annotations

import math

import anyio
import pytest

from skill_agent import SkillLoadError
from skill_agent.protocol import SkillDescription, StartRun
from skill_agent.runtime import SimulatedOutcomes, skill_probability
from tests.assets.skills import Noop, Pick, PickAndPlace, Place, Probe, Slow, entries

from .conftest import AgentFactory, Kitting

pytestmark = pytest.mark.anyio


class Shaky(Noop):
    description = SkillDescription(name="shaky", skill_type="wobble")
    success_probability = 0.25


def test_probability_lookup_order() -> None:
    outcomes = SimulatedOutcomes({"noop": 0.5, "wobble": 0.75}, default=0.9)
    assert outcomes.probability("noop") == 0.5
    assert outcomes.probability("shaky", family="wobble", implementation=Shaky) == 0.75
    assert outcomes.probability("shaky", implementation=Shaky) == 0.25  # the class says so
    assert outcomes.probability("slow", implementation=Slow) == 0.9  # nobody says: default
    assert skill_probability(Shaky) == 0.25 and skill_probability(Noop) is None
    with pytest.raises(SkillLoadError, match="in \\[0, 1\\]"):
        SimulatedOutcomes({"noop": 1.5})


def test_seeded_draws_repeat_and_instances_are_independent() -> None:
    a, b = SimulatedOutcomes(default=0.5, seed=7), SimulatedOutcomes(default=0.5, seed=7)
    draws_a = [a.draw("x") for _ in range(50)]
    assert draws_a == [b.draw("x") for _ in range(50)]
    assert 0 < sum(draws_a) < 50
    assert all(SimulatedOutcomes(default=1.0).draw("x") for _ in range(20))
    assert not any(SimulatedOutcomes(default=0.0).draw("x") for _ in range(20))


async def test_200_simulated_runs_succeed_with_probability_p(
    make_agent: AgentFactory, probe: Probe
) -> None:
    n, p = 200, 0.7
    async with make_agent(simulated=SimulatedOutcomes({"noop": p}, seed=20240611)) as core:
        with anyio.fail_after(20):
            results = [
                await core.wait((await core.start(StartRun(skill="noop"))).run_id) for _ in range(n)
            ]
    successes = sum(r.success for r in results)
    bound = 4 * math.sqrt(n * p * (1 - p))  # 4 sigma: a false alarm once in ~16000 seeds
    print(f"\n{successes}/{n} simulated successes, p = {p}, bound +-{bound:.1f}")
    assert abs(successes - n * p) <= bound, (successes, n * p, bound)
    assert {r.reason for r in results} == {"ok", "execution"}
    assert all("p(success) = 0.7" in r.message for r in results if not r.success)
    assert probe.calls == []  # no skill code ran


async def test_success_commits_effects_and_failure_commits_nothing(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    gear = kitting["gear1"]
    async with make_agent(simulated=SimulatedOutcomes({"pick": 0.0})) as core:
        before = kitting.wm.revision
        failed = await core.wait(
            (await core.start(StartRun(skill="pick", params={"obj": gear}))).run_id
        )
        assert failed.reason == "execution" and kitting.wm.revision == before
    async with make_agent(simulated=SimulatedOutcomes({"pick": 1.0})) as core:
        ok = await core.wait(
            (await core.start(StartRun(skill="pick", params={"obj": gear}))).run_id
        )
    assert ok.success and ok.message == "simulated success"
    assert ok.effects_revision == kitting.wm.revision
    assert kitting.wm.get_parent(gear).id == kitting["left"]  # type: ignore[union-attr]
    assert probe.calls == []


async def test_simulate_flag_on_a_real_agent_and_preconditions_still_apply(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    async with make_agent() as core:
        assert core.simulated is None
        first = await core.start(
            StartRun(skill="pick", params={"obj": kitting["gear1"]}, simulate=True)
        )
        assert (await core.wait(first.run_id)).success
        assert core.status(first.run_id).result.params["gripper"] == kitting["left"]  # type: ignore[union-attr]
        with pytest.raises(Exception, match="pre-condition false"):
            await core.start(
                StartRun(
                    skill="pick",
                    params={"obj": kitting["gear2"], "gripper": kitting["left"]},
                    simulate=True,
                )
            )
    assert probe.calls == []


async def test_simulated_composite_runs_its_children_simulated(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    catalog = entries(probe, Pick, Place, PickAndPlace)
    async with make_agent(catalog, simulated=SimulatedOutcomes(seed=1)) as core:
        started = await core.start(
            StartRun(
                skill="pick_and_place",
                params={"obj": kitting["gear2"], "container": kitting["kit"]},
            )
        )
        result = await core.wait(started.run_id)
        children = [
            r for r in core.runs(active_only=False) if r.run_id.startswith(f"{started.run_id}.")
        ]
    assert result.success
    assert [c.skill for c in children] == ["pick", "place"]
    assert all(c.result is not None and c.result.message == "simulated success" for c in children)
    assert kitting.wm.get_parent(kitting["gear2"]).id == kitting["kit"]  # type: ignore[union-attr]
    assert probe.calls == []


async def test_simulated_duration_can_be_stopped(make_agent: AgentFactory) -> None:
    outcomes = SimulatedOutcomes(time_scale=1000.0)  # slow: 0.01 s x 1000 = 10 s
    async with make_agent(simulated=outcomes) as core:
        started = await core.start(StartRun(skill="slow"))
        with anyio.fail_after(2):
            result = await core.stop(started.run_id)
    assert result.reason == "preempted"
