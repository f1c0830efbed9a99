"""Robots: the `droid` agent (Panda + Robotiq 2F-85, registered with ManiSkill on import) and the bindings that
let RoboLabEnv run it, ManiSkill's `panda` or `so100` (see `ROBOT_BINDINGS`)."""

# bindings before droid: once droid brings ManiSkill up, its start-up hook registers RoboLabEnv, which needs them
from robolab_ms.agents.bindings import DEFAULT_ROBOT, ROBOT_BINDINGS, RobotBinding, robot_binding
from robolab_ms.agents.droid import DroidPandaRobotiq

__all__ = ["DEFAULT_ROBOT", "ROBOT_BINDINGS", "RobotBinding", "DroidPandaRobotiq", "robot_binding"]
