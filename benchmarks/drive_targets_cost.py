"""What a random-policy control step of `robolab validate` costs with the droid agent's controllers, which write the
CPU simulator's drive targets in one pass (robolab_ms/agents/controllers.py), against ManiSkill's controllers, which
write them joint by joint through a tensor conversion each (the baseline), in one environment.

On one task's validation environment (no observations, events off, as validation runs its random episodes), the
script alternates blocks of the same random steps from the same state with the two ways of writing the targets, and
prints for each the CPU milliseconds per step spent in the arm's and gripper's controllers (the agent's set_action)
and in the whole step, and the ratio of the controllers' cost. The whole step follows the machine's other load far
more than this change (its physics is the same in both ways); the controllers' cost does not. Both ways set the
same numbers (tests/test_controllers.py).

    .venv/bin/python benchmarks/drive_targets_cost.py [--task ClutterPlastic] [--steps 300] [--rounds 5]
"""

from __future__ import annotations

import argparse
import statistics
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="ClutterPlastic", help="task whose validation environment is stepped")
    parser.add_argument("--steps", type=int, default=300, help="random steps per timed block")
    parser.add_argument("--rounds", type=int, default=5, help="timed blocks of each kind")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.rounds = 3, 1

    import numpy as np
    from mani_skill.agents.controllers import PDJointPosController, PDJointPosMimicController

    from robolab_ms.agents.controllers import JointPosController, MimicJointPosController
    from robolab_ms.eval.validate import validation_config, validation_env
    from robolab_ms.tasks.spec import load_task

    spec = load_task(args.task)
    env = validation_env(str(spec.file), validation_config((str(spec.file),), 1, 0, None))
    env.unwrapped.track_events = False
    env.reset(seed=0)
    space = env.action_space
    rng = np.random.default_rng(0)
    actions = [rng.uniform(space.low, space.high).astype(np.float32) for _ in range(args.steps)]
    start = env.unwrapped.get_state_dict()
    ours = {cls: cls.set_drive_targets for cls in (JointPosController, MimicJointPosController)}
    maniskill = {
        JointPosController: PDJointPosController.set_drive_targets,
        MimicJointPosController: PDJointPosMimicController.set_drive_targets,
    }

    agent_class = type(env.unwrapped.agent)  # restoring the state rebuilds the scene, and the agent with it
    set_action = agent_class.set_action
    in_controllers = [0.0]

    def timed_set_action(agent, action):
        began = time.process_time()
        set_action(agent, action)
        in_controllers[0] += time.process_time() - began

    agent_class.set_action = timed_set_action

    def block(writers: dict) -> tuple[float, float]:
        for cls, writer in writers.items():
            cls.set_drive_targets = writer
        env.unwrapped.set_state_dict(start)  # every block steps the same actions from the same state
        in_controllers[0], began = 0.0, time.process_time()
        for action in actions:
            env.step(action)
        step_seconds = time.process_time() - began
        return in_controllers[0] / args.steps * 1000, step_seconds / args.steps * 1000

    mine, baseline = [], []
    try:
        for _ in range(args.rounds):
            mine.append(block(ours))
            baseline.append(block(maniskill))
    finally:
        for cls, writer in ours.items():
            cls.set_drive_targets = writer
        agent_class.set_action = set_action
        env.close()
    mine_ms, baseline_ms = (statistics.median(ms for ms, _ in runs) for runs in (mine, baseline))
    mine_step, baseline_step = (statistics.median(ms for _, ms in runs) for runs in (mine, baseline))
    print(f"{args.task}: {args.rounds} blocks of {args.steps} random steps each way (CPU milliseconds per step)")
    print(f"targets in one pass (ours):   controllers {mine_ms:.3f}, whole step {mine_step:.2f}")
    print(f"joint by joint (ManiSkill's): controllers {baseline_ms:.3f}, whole step {baseline_step:.2f}")
    print(f"ratio of the controllers' cost, ours / ManiSkill's: {mine_ms / baseline_ms:.3f}")


if __name__ == "__main__":
    main()
