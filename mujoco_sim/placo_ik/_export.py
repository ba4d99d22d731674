"""Export a MuJoCo robot model in the MJCF subset placo (pinocchio's MJCF parser) reads right.

Fixes applied to ``MjSpec.to_xml()`` output (measured with placo 0.10.2):

- Keyframes are removed (the parser rejects them), and so are the elements IK does not need
  (actuators, tendons, equalities, contact excludes/pairs, sensors, lights, cameras).
- Static (joint-less) bodies are fused into their parents (``MjSpec.fuse_static``): the parser
  places a site in a static body nested in another static body wrong (it keeps only the last
  body's offset; seen with the Robotiq 2F-85's ``pinch`` site on a UR5e, 0.3 m off).
- ``<frame>`` elements (which ``MjSpec.attach`` and ``fuse_static`` write) are flattened into
  their children: the parser skips frame contents.
- The robot is wrapped in an identity root body ``ik_root`` with a free joint. The parser
  ignores the root body's own pose, and placo's kinematics solver assumes the first 6 velocity
  DOFs are a floating base: it applies joint limits only to DOFs 6.., so a fixed-base model
  would get its first six joints unlimited. Solvers mask the dummy base (``mask_fbase``).
- Mesh geoms and mesh assets are dropped unless ``keep_meshes`` (IK needs no geometry and
  ``to_xml`` loses the mesh directories of attached models).

Several joints in one body would merge into one composite joint: models must have one joint
per body (the generated robots do).
"""

from __future__ import annotations

import ctypes
import os
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeAlias

import mujoco
import numpy as np
import numpy.typing as npt

from device_drivers import ModelError
from mujoco_sim.placo_ik._import import placo

__all__ = ["IK_ROOT", "load_placo_robot", "placo_mjcf"]

IK_ROOT = "ik_root"
"""Name of the wrapper body and its free joint in the exported model."""

_DROPPED = (
    "keys",
    "actuators",
    "tendons",
    "equalities",
    "excludes",
    "pairs",
    "sensors",
    "lights",
    "cameras",
)
_POSED = ("body", "geom", "site", "camera", "light")
FloatArray: TypeAlias = npt.NDArray[np.float64]


def placo_mjcf(robot: mujoco.MjSpec, *, keep_meshes: bool = False) -> str:
    """The MJCF text of ``robot`` with the fixes listed in the module doc.

    ``robot`` is not modified (a copy is compiled). Raises :class:`ModelError` if it does not
    compile or has no body.
    """
    spec = robot.copy()
    for kind in _DROPPED:  # actuators before the tendons they drive
        for element in list(getattr(spec, kind)):
            spec.delete(element)
    spec.compiler.savecompiled = True  # poses as compiled: pos + quat, no euler/fromto
    try:
        if spec.fuse_static() < 0:  # static bodies → frames (flattened below)
            raise ValueError("mjs_fuseStatic failed")
        root = ET.fromstring(spec.to_xml())
    except ValueError as exc:
        raise ModelError(f"cannot export for placo: {exc}", source=spec.modelname) from exc
    for size in root.findall("size"):  # may still count the deleted keyframes
        root.remove(size)
    worldbody = root.find("worldbody")
    if worldbody is not None:
        _flatten_frames(worldbody)
    if worldbody is None or worldbody.find("body") is None:
        raise ModelError("the model has no moving body to export", source=spec.modelname)
    if not keep_meshes:
        _drop_meshes(root)
    wrapper = ET.Element("body", {"name": IK_ROOT})
    ET.SubElement(wrapper, "freejoint", {"name": IK_ROOT})
    for body in worldbody.findall("body"):
        worldbody.remove(body)
        wrapper.append(body)
    worldbody.append(wrapper)
    return ET.tostring(root, encoding="unicode")


def load_placo_robot(robot: mujoco.MjSpec, *, keep_meshes: bool = False) -> Any:
    """A ``placo.RobotWrapper`` of ``robot`` (exported with :func:`placo_mjcf` to a temporary
    directory, loaded with ``placo.Flags.mjcf``, self-collision pairs ignored).

    Returns ``Any``: placo has no type information. Raises :class:`ModelError` if placo
    rejects the model (the message names the temporary file and placo's reason).
    """
    text = placo_mjcf(robot, keep_meshes=keep_meshes)
    with tempfile.TemporaryDirectory(prefix="skimesh-placo-") as tmp:
        path = Path(tmp) / "robot.xml"
        path.write_text(text, encoding="utf-8")
        flags = placo.Flags.mjcf | placo.Flags.ignore_collisions
        try:
            with _c_stdout_to(Path(tmp) / "placo.out"):  # placo prints "Loading model: ..."
                return placo.RobotWrapper(str(path), flags)
        except RuntimeError as exc:
            raise ModelError(f"placo cannot load the model: {exc}", source=str(path)) from exc


@contextmanager
def _c_stdout_to(file: Path) -> Iterator[None]:
    """Send what C and C++ code print on the process's stdout to ``file`` while the block runs
    (placo announces every model it loads there, which would mix with a command's output).
    Python's own ``sys.stdout`` is flushed first; the C library's buffers before restoring."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(file, "wb") as sink:
            os.dup2(sink.fileno(), 1)
            try:
                yield
            finally:
                _LIBC.fflush(None)
                os.dup2(saved, 1)
    finally:
        os.close(saved)


_LIBC = ctypes.CDLL(None)


def _pose(elem: ET.Element) -> tuple[FloatArray, FloatArray]:
    pos = np.array([float(v) for v in elem.get("pos", "0 0 0").split()])
    quat = np.array([float(v) for v in elem.get("quat", "1 0 0 0").split()])
    return pos, quat / np.linalg.norm(quat)


def _flatten_frames(parent: ET.Element) -> None:
    """Replace every ``<frame>`` under ``parent`` by its children, poses composed."""
    children: list[ET.Element] = []
    for child in parent:
        _flatten_frames(child)  # inner frames first: a frame then holds no frame
        if child.tag != "frame":
            children.append(child)
            continue
        f_pos, f_quat = _pose(child)
        for grandchild in child:
            if grandchild.tag in _POSED:
                pos, quat = _pose(grandchild)
                new_pos, new_quat = np.zeros(3), np.zeros(4)
                mujoco.mju_rotVecQuat(new_pos, pos, f_quat)
                mujoco.mju_mulQuat(new_quat, f_quat, quat)
                grandchild.set("pos", " ".join(f"{v:.17g}" for v in new_pos + f_pos))
                grandchild.set("quat", " ".join(f"{v:.17g}" for v in new_quat))
            children.append(grandchild)
    parent[:] = children


def _drop_meshes(root: ET.Element) -> None:
    """Remove mesh assets and every geom that uses one (by ``type`` or ``mesh`` attribute)."""
    for elem in list(root.iter()):
        for child in list(elem):
            is_mesh_geom = child.tag == "geom" and (
                child.get("type") == "mesh" or child.get("mesh") is not None
            )
            if is_mesh_geom or child.tag == "mesh":
                elem.remove(child)
