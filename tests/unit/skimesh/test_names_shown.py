"""The terminal names elements as everything else does (``wm_store.display_name``): the plan
``skimesh task plan`` prints and the element lines of ``skimesh wm``."""

from __future__ import annotations

from skimesh.commands._plan import named_order
from skimesh.commands._render import element_line
from task_agent.planning import PartialOrderPlan, PlanStep, ScheduledStep
from wm_store.protocol import Element

ELEMENTS = {
    "Gear-1": Element(id="Gear-1", type="Gear", label="Pulley-4"),
    "Camera-1": Element(id="Camera-1", type="Camera", label="Camera-1"),
    "Camera-2": Element(id="Camera-2", type="Camera", label="r1-camera"),
}


def test_the_printed_plan_names_elements_by_label_and_id_where_they_differ() -> None:
    step = PlanStep(
        index=0,
        action="locate__r1",
        agent="r1",
        skill="locate",
        args=("Gear-1", "Camera-1"),
        params={"object": "Gear-1", "sensor": "Camera-1", "mode": "fast"},
        duration=1.0,
    )
    order = PartialOrderPlan(
        steps=(ScheduledStep(step=step, start=0.0, finish=1.0, resources=("Camera-1",)),),
        edges=(),
        makespan=1.0,
        sequential=1.0,
    )
    text = named_order(order, ELEMENTS.get).render()
    assert "locate(object=Pulley-4 (Gear-1), sensor=Camera-1, mode=fast)" in text
    assert order.steps[0].step.params["object"] == "Gear-1", "the plan itself keeps the ids"


def test_element_lines_use_the_same_name() -> None:
    assert element_line(ELEMENTS["Camera-2"]) == "r1-camera (Camera-2) [Camera]"
    assert element_line(ELEMENTS["Camera-1"]) == "Camera-1 [Camera]"
