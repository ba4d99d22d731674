"""``python -m mujoco_sim.models SCENARIO``: build each robot of a scenario alone and print what
was derived (mount, names, chain, tool frame, gripper). A robot file problem prints its
:class:`~scenario.RobotFileError` (the file, what is missing, the key to set) and exits 1."""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco
import numpy as np

from mujoco_sim.models._robot import build_robot
from scenario import ScenarioError, describe_file, read_scenario, robot_layout


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: python -m mujoco_sim.models SCENARIO (file, or name in configs/scenarios)")
        return 2
    try:
        scenario = read_scenario(argv[0], Path.cwd() / "configs/scenarios")
        for robot in scenario.robots:
            spec, files = robot.spec, robot.spec.mjcf
            print(f"robot {robot.name}:")
            if files is not None and files.one_file:
                print(f"  {describe_file(files)}")
            names = robot_layout(spec)
            model = build_robot(spec).compile()
            data = mujoco.MjData(model)
            mujoco.mj_forward(model, data)
            act = model.actuator(names.gripper_actuator).id
            site = model.site(names.tcp_site).id
            print(
                f"  mount {spec.mount}: the arm's mount {spec.mount_height:.3f} m above the floor"
                + (f", devices {spec.devices} (no base)" if spec.fixed else "")
            )
            print(f"  arm joints: {names.arm_joints}")
            body = model.body(model.site_bodyid[site]).name
            pos, quat = np.round(model.site_pos[site], 4), np.round(model.site_quat[site], 4)
            print(f"  tcp site {names.tcp_site} on body {body} at {pos} quat {quat}")
            ctrl = np.round(model.actuator_ctrlrange[act], 4)
            print(f"  gripper actuator {names.gripper_actuator}: ctrl range {ctrl}")
            print(f"  fingers {names.finger_joints}")
            print(f"  pads {names.pad_geoms}; hand body {names.hand_body}")
    except ScenarioError as exc:  # RobotFileError included
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
