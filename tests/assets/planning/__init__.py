"""Planning test assets: a synchronous world view over a scene, kitting skill descriptions
as the standard library will offer them, and scene builders (``tests.assets.planning``)."""

from task_agent.verification import SceneView

from .kitting import (
    NAVIGATE,
    OPEN_DOOR,
    PICK,
    PLACE,
    TAKE_OUT,
    KittingScene,
    add_microwave,
    apply_ops,
    kitting_scene,
)

__all__ = [
    "NAVIGATE",
    "OPEN_DOOR",
    "PICK",
    "PLACE",
    "TAKE_OUT",
    "KittingScene",
    "SceneView",
    "add_microwave",
    "apply_ops",
    "kitting_scene",
]
