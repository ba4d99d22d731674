"""Device bindings, published: how an agent's configured devices reach its planners.

An agent's configuration may bind a hardware parameter to a device (``[hardware]
sensor = "Camera-1"``: the overhead camera, not the robot's own). The agent resolves the label
to the element id once (:func:`skill_agent.runtime.bind_hardware`) and every run gets that
device (:func:`~skill_agent.parameters.specify`). So that a plan names the same device, the
agent registers its skills with :func:`with_bindings`: each bound hardware parameter's
``default`` is the bound device. Whoever grounds a hardware parameter (the run's
``specify``, the task agent's domain, its verification and lock prediction) reads the binding
back with :func:`bindings` and takes it before any choice of its own: one binding, one device.
"""

from __future__ import annotations

from collections.abc import Mapping

import msgspec

from skill_agent.protocol import SkillDescription

__all__ = ["bindings", "with_bindings"]


def with_bindings(desc: SkillDescription, hardware: Mapping[str, str]) -> SkillDescription:
    """``desc`` with each hardware parameter that ``hardware`` binds (a key equal to its name;
    parameter -> device element id) defaulting to that device; ``desc`` itself if none."""
    bound = {
        p.name: hardware[p.name]
        for p in desc.parameters
        if p.kind == "hardware" and p.name in hardware
    }
    if not bound:
        return desc
    parameters = [
        msgspec.structs.replace(p, default=bound[p.name]) if p.name in bound else p
        for p in desc.parameters
    ]
    return msgspec.structs.replace(desc, parameters=parameters)


def bindings(desc: SkillDescription) -> dict[str, str]:
    """Hardware parameter -> the device its agent binds it to (the published defaults)."""
    return {
        p.name: p.default
        for p in desc.parameters
        if p.kind == "hardware" and isinstance(p.default, str) and p.default
    }
