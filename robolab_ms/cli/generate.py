"""`robolab generate`: scenes and tasks from a prompt, by an LLM or offline; the options and the runs are in
`robolab_ms.generation.commands`."""

from __future__ import annotations

from robolab_ms.physics import MAX_DRIFT_M, STABILITY_PHYSICS_STEPS


def add_generate_command(commands) -> None:
    """Add `robolab generate` to the commands."""
    from robolab_ms.generation import commands as generation

    generate = commands.add_parser(
        "generate",
        help="generate scenes and tasks with an LLM or offline, checked like hand-written ones",
        description="Generated content is data: it passes the same "
        "checks as hand-written files. See docs/generation.md.",
    )
    kinds = generate.add_subparsers(dest="generate_kind", required=True, metavar="KIND")
    scene = kinds.add_parser(
        "scene",
        help="a scene file from a prompt: relations, solvers, physics settle, feedback rounds",
        description="The model (--llm openai or offline) picks catalog objects and placement relations; a physical "
        "solver puts objects on, in and stacked on others, a spatial solver places the rest in the reachable area; "
        f"a physics settle (no object may move more than {MAX_DRIFT_M * 100:.0f} cm in {STABILITY_PHYSICS_STEPS} "
        "steps) checks it. Failures go back to the model for at most --rounds rounds. Writes FILE.yaml, its preview "
        "FILE.png and FILE.transcript.json.",
    )
    generation.add_scene_arguments(scene)
    scene.set_defaults(run=generation.run_scene)
    task = kinds.add_parser(
        "task",
        help="a task file from an instruction on a scene: schema, judge and `robolab validate`, feedback rounds",
        description="The model (--llm openai or offline) proposes the success condition with our predicates, the "
        "three instruction variants, attributes, subtasks and the episode length. Each answer must pass the task "
        "loader, a judge (the condition matches the instruction: the LLM, or rules offline) and `robolab validate` "
        "(stable at rest, not solved at reset, not by the random policy, solved by the oracle) over --seeds seeds; "
        "failures go back to the model for at most --rounds rounds. Writes FILE.yaml only when all pass, and "
        "FILE.transcript.json.",
    )
    generation.add_task_arguments(task)
    task.set_defaults(run=generation.run_task)
