"""The `robolab` command line: list tasks, evaluate policies, validate tasks, build and check the catalog.

Examples:
  robolab list
  robolab eval --policy random --task BananaInBowl --episodes 2 --out results/demo
  robolab catalog build | check [--objects NAME ...] | sheet | list
  robolab scene export kitchen_table --usd out/kitchen_table.usda   # and: robolab scene import FILE.usda
  robolab eval --policy oracle --task BananaInBowl --episodes 10
  robolab validate --task BananaInBowl --seeds 10
  robolab eval --policy oracle --task BananaInBowl --vary lighting,objects=0.2   # domain randomization
  robolab suites                                        # then: robolab eval --suite lighting ...
  robolab serve --policy random --port 8000            # then: robolab eval --policy openpi --port 8000 ...
  robolab eval --policy random --task all --episodes 20 --workers 2    # or --ray ADDRESS / auto / local
  robolab export lerobot results/demo datasets/demo     # episodes recorded with --record-images
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from robolab_ms.errors import RoboLabError

if TYPE_CHECKING:
    from robolab_ms.policies import PolicyOptions


def _task_arguments(tasks: list[str]) -> tuple[str, ...]:
    """The `--task` values, each checked: a known task's name, or a task file's path. A task file is registered as
    `RoboLab-<name>-v1` for this run (replacing a known task of the same name, with a note)."""
    from robolab_ms.tasks.spec import is_task_file, load_task, task_names

    resolved, names = [], {}
    for task in tasks:
        spec = load_task(task)  # unknown names and bad files fail here, with suggestions
        if spec.name in names:
            raise RoboLabError(f"--task: '{names[spec.name]}' and '{task}' are both the task {spec.name}; give it once")
        names[spec.name] = task
        if not is_task_file(task):
            resolved.append(spec.name)
            continue
        import robolab_ms.envs  # registers the known tasks first

        if spec.name in task_names() and robolab_ms.envs.registered_file(spec.env_id) != spec.file:
            print(
                f"robolab: note: {spec.file} replaces the task {spec.name} of "
                f"{robolab_ms.envs.registered_file(spec.env_id)} in this run; results are filed under its name",
                file=sys.stderr,
            )
        robolab_ms.envs.register_task_file(spec.file, replace=True)
        resolved.append(str(spec.file))
    return tuple(resolved)


def _add_task_filters(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group(
        "task selection",
        "--task all takes every known task; these filters narrow --task (or all tasks when "
        "--task is not given). Different filters must all hold; several values of one mean any of them.",
    )
    group.add_argument(
        "--tag",
        nargs="+",
        metavar="TAG",
        help="attribute (color, semantics, size, conjunction, "
        "counting, spatial, affordance, reorientation, stacking, sorting, vague) or competency axis "
        "(visual, relational, procedural), e.g. --tag spatial",
    )
    group.add_argument("--difficulty", nargs="+", metavar="LEVEL", help="simple, moderate or complex")
    group.add_argument("--scene", nargs="+", metavar="SCENE", help="scene name, as in `robolab list`")


def _select_tasks(args: argparse.Namespace) -> None:
    """Expand `--task all` and apply --tag / --difficulty / --scene: `args.task` becomes the chosen tasks."""
    from robolab_ms.tasks.selection import select_tasks

    args.task = select_tasks(getattr(args, "task", None), args.tag, args.difficulty, args.scene)


def _cmd_list(args: argparse.Namespace) -> int:
    if args.format != "text" and not args.summary:
        raise RoboLabError(f"--format {args.format} applies to the totals: add --summary")
    named = None if not args.task or "all" in args.task else list(args.task)  # before the filters narrow it
    _select_tasks(args)
    from robolab_ms.content import content_dirs
    from robolab_ms.tasks.spec import load_all_tasks, load_task

    tasks = [load_task(task) for task in args.task] if args.task else load_all_tasks()
    if args.summary:
        from robolab_ms.tasks.summary import listing_summary, render

        print(render(listing_summary(tasks, named, args.tag, args.difficulty, args.scene), args.format), end="")
        return 0
    rows = [("task", "env id", "scene", "attributes", "axes", "subtasks", "difficulty", "seconds")]
    for spec in tasks:
        rows.append(
            (
                spec.name,
                spec.env_id,
                spec.scene.name,
                ",".join(spec.attributes) or "-",
                ",".join(spec.axes) or "-",
                str(spec.num_subtasks),
                f"{spec.difficulty} ({spec.difficulty_score})",
                f"{spec.episode_seconds:g}",
            )
        )
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        print("  ".join(cell.ljust(width) for cell, width in zip(row, widths)).rstrip())
    print(f"\n{len(tasks)} task(s)")
    if not args.task:
        print("task folders: " + ", ".join(str(folder.resolve()) for folder in content_dirs("tasks")))
    return 0


def _cmd_eval(args: argparse.Namespace) -> int:
    from robolab_ms.analysis.tables import SUMMARY_MD, summary_markdown, write_summary
    from robolab_ms.eval.results import EPISODES_FILE
    from robolab_ms.eval.runner import EvalConfig
    from robolab_ms.policies import make_policy
    from robolab_ms.tasks.spec import INSTRUCTION_VARIANTS

    if args.episodes < 1:
        raise RoboLabError(f"--episodes must be at least 1, got {args.episodes}")
    if args.max_steps is not None and args.max_steps < 1:
        raise RoboLabError(f"--max-steps must be at least 1, got {args.max_steps}")
    if args.seed < 0:
        raise RoboLabError(f"--seed must be 0 or more (episode seeds are --seed, --seed+1, ...), got {args.seed}")
    if args.workers is not None and args.workers < 1:
        raise RoboLabError(f"--workers must be at least 1, got {args.workers}")
    _check_adaptive(args)
    _select_tasks(args)
    if not args.task:
        raise RoboLabError(
            "name the tasks with --task NAME ... (or --task all), or choose them with --tag, --difficulty or --scene"
        )
    if args.instruction not in INSTRUCTION_VARIANTS:
        raise RoboLabError(f"--instruction must be one of {', '.join(INSTRUCTION_VARIANTS)}")
    policy = make_policy(args.policy, _policy_options(args))
    tasks = _task_arguments(args.task)  # unknown names and bad files fail here, with suggestions
    robot = None
    if args.robot:
        import robolab_ms.envs  # noqa: F401  (registers the environments and the robots)
        from robolab_ms.agents import robot_binding

        robot = robot_binding(args.robot).uid
    config = EvalConfig(
        tasks=tasks,
        episodes=args.episodes,
        instruction=args.instruction,
        robot=robot,
        first_seed=args.seed,
        max_steps=args.max_steps,
        record=_record_options(args),
        episodes_adaptive=args.episodes_adaptive,
        ci_width=args.ci_width,
        retry_errors=args.retry_errors,
        save_actions=args.save_actions,
        reconnect_seconds=args.reconnect_seconds,
        variations=_vary_text(args.vary),
    )
    out = Path(args.out)
    if args.suite:
        return _run_suite(args, policy, config, out)
    try:
        results = _run(args, policy, config, out)
    except KeyboardInterrupt:
        from robolab_ms.eval.results import read_results

        write_summary([r for r in read_results(out) if r.policy == policy.name], out)  # tables of what finished
        print(
            f"\ninterrupted: finished episodes are kept in {out / EPISODES_FILE}; run the same command again to resume",
            file=sys.stderr,
        )
        return 130
    table = write_summary(results, out)
    print(summary_markdown(table))
    print(f"episodes: {out / EPISODES_FILE}\nsummary:  {out / SUMMARY_MD} (and summary.csv)")
    return 0


def _run(args: argparse.Namespace, policy, config, out: Path) -> list:
    """Run one evaluation into `out`: in this process, or in --workers processes / on a --ray cluster."""
    from robolab_ms.eval.runner import run_evaluation

    if args.ray or (args.workers or 1) > 1:
        from robolab_ms.eval.parallel import PolicySpec, run_parallel

        return run_parallel(
            policy,
            PolicySpec(args.policy, _policy_options(args)),
            config,
            out,
            workers=args.workers,
            ray=args.ray,
            show_progress=not args.quiet,
        )
    return run_evaluation(policy, config, out, show_progress=not args.quiet)


def _vary_text(vary: list[str] | None) -> str | None:
    """The `--vary` settings as one checked text (None when not given)."""
    if not vary:
        return None
    from robolab_ms.variations import Variations

    return Variations.create(",".join(vary)).text or None


def _run_suite(args: argparse.Namespace, policy, config, out: Path) -> int:
    """Run every condition of `--suite` into OUT/<condition>/ (with any --vary settings first), then write
    OUT/suite.csv and OUT/suite.md."""
    from dataclasses import replace

    from robolab_ms.variations import suite_conditions
    from robolab_ms.variations.suites import suite_summary

    suite, conditions = suite_conditions(args.suite)
    for condition, settings in conditions.items():
        text = _vary_text([t for t in (config.variations, settings) if t])
        folder = out / condition
        print(f"suite {suite.name}: condition {condition} ({text or 'nothing varies'}) -> {folder}", file=sys.stderr)
        try:
            _run(args, policy, replace(config, variations=text, condition=condition), folder)
        except KeyboardInterrupt:
            print(
                f"\ninterrupted: finished episodes are kept in {out}/<condition>/; run the same command again to "
                "resume",
                file=sys.stderr,
            )
            return 130
    markdown = suite_summary(out, suite, list(conditions), policy.name)
    print(markdown.read_text(encoding="utf-8"))
    print(f"suite summary: {markdown} (and suite.csv); episodes: {out}/<condition>/episodes.jsonl")
    return 0


def _cmd_suites(args: argparse.Namespace) -> int:
    from robolab_ms.variations import AXES, suites

    for suite in suites().values():
        print(f"{suite.name}: {suite.description}")
        width = max(len(c) for c in suite.conditions)
        for condition, settings in suite.conditions.items():
            print(f"  {condition.ljust(width)}  {settings or '(nothing varies)'}")
    print("\naxes for --vary (AXIS, AXIS=VALUE, AXIS.PARAM=VALUE; see docs/variations.md):")
    for axis in AXES.values():
        params = ", ".join(p.name for p in axis.params)
        print(f"  {axis.name}: {axis.summary} [{params}]")
    print("\nrun one with: robolab eval --suite NAME[:CONDITION/CONDITION] --policy ... --task ... --out DIR")
    return 0


def _policy_options(args: argparse.Namespace) -> PolicyOptions:
    from robolab_ms.policies import PolicyOptions

    horizon, timeout = getattr(args, "open_loop_horizon", 8), getattr(args, "timeout", 60.0)
    if horizon < 1:
        raise RoboLabError(f"--open-loop-horizon must be at least 1, got {horizon}")
    if not timeout > 0:
        raise RoboLabError(f"--timeout must be a positive number of seconds, got {timeout}")
    return PolicyOptions(
        host=args.host,
        port=args.port,
        open_loop_horizon=horizon,
        timeout=timeout,
        replay_from=Path(args.replay_from) if args.replay_from else None,
        replay_policy=args.replay_policy,
        action_horizon=getattr(args, "action_horizon", 10),
        gr00t_version=getattr(args, "gr00t_version", "n1.6"),
        results_name=_results_name(getattr(args, "policy_name", None)),
        realtime=getattr(args, "realtime", False),
    )


def _results_name(name: str | None) -> str | None:
    """--policy-name, checked: results, tables and the leaderboard show it."""
    if name is None:
        return None
    if not name.strip() or any(ch in name for ch in "\n\r\t"):
        raise RoboLabError(f"--policy-name {name!r}: give a non-blank name on one line, e.g. --policy-name pi05")
    return name


def _add_policy_options(parser: argparse.ArgumentParser, default_host: str, client: bool = True) -> None:
    group = parser.add_argument_group(
        "policy options",
        "openpi: DROID observations (224x224 images padded, joints, gripper, prompt) over openpi's websocket "
        "protocol; gr00t: GR00T's DROID keys (180x320 images, joints, gripper, eef_9d) over ZMQ + msgpack; "
        "replay: actions recorded with --save-actions; module.path:factory: an in-process LeRobot-style policy "
        "(reset(), select_action(batch)). See docs/policies.md.",
    )
    group.add_argument("--host", default=default_host, help=f"policy server host (default: {default_host})")
    group.add_argument(
        "--port", type=int, default=None, help="policy server port (default: 8000 for openpi, 5555 for gr00t)"
    )
    if client:
        group.add_argument(
            "--open-loop-horizon",
            type=int,
            default=8,
            metavar="N",
            help="actions of each chunk executed before the server is asked again (default: 8)",
        )
        group.add_argument(
            "--timeout",
            type=float,
            default=60.0,
            metavar="SECONDS",
            help="longest wait for one reply; a later one errors the episode (default: 60)",
        )
        group.add_argument(
            "--realtime",
            action="store_true",
            help="openpi, gr00t: the simulation does not wait for the policy; its measured latency "
            "passes in simulated time at 15 Hz (the arm goes on with its chunk, then holds; late "
            "actions are skipped). Results record latency and held steps (docs/policies.md)",
        )
        group.add_argument(
            "--gr00t-version",
            choices=("n1.6", "n1.5"),
            default="n1.6",
            help="gr00t: the server's request format, N1.6's policy server (default) or N1.5's inference service",
        )
    group.add_argument("--replay-from", metavar="DIR", help="replay: a results folder written with --save-actions")
    group.add_argument(
        "--replay-policy",
        metavar="NAME",
        help="replay: whose actions, when DIR holds several policies' (default: the only one)",
    )


def _cmd_serve(args: argparse.Namespace) -> int:
    from robolab_ms.policies import make_policy
    from robolab_ms.policies.server import PROTOCOLS, serve

    if args.policy in ("openpi", "gr00t"):
        raise RoboLabError(
            f"--policy {args.policy} is a client; serve one of our policies (random, hold, replay, module.path:factory)"
        )
    if args.action_horizon < 1:
        raise RoboLabError(f"--action-horizon must be at least 1, got {args.action_horizon}")
    if not args.delay_ms >= 0:
        raise RoboLabError(f"--delay-ms must be a number of milliseconds, 0 or more, got {args.delay_ms}")
    options = _policy_options(args)
    first = make_policy(args.policy, options)  # a bad name or option fails here, before the port opens
    if first.privileged:
        raise RoboLabError(f"policy '{args.policy}' reads the simulator's state and cannot be served")
    first.close()
    port = args.port or PROTOCOLS[args.protocol]

    def ready() -> None:
        client = f"--policy {args.protocol} --port {port}"
        delay = f", answers after {args.delay_ms:g} ms at the soonest" if args.delay_ms else ""
        print(
            f"robolab serve: policy '{first.name}' on {args.host}:{port} ({args.protocol} protocol, chunks of "
            f"{args.action_horizon}{delay}); evaluate with `robolab eval {client} --task ...`; Ctrl-C stops",
            flush=True,
        )

    try:
        serve(
            lambda: make_policy(args.policy, options),
            args.host,
            port,
            args.protocol,
            args.action_horizon,
            ready,
            log_requests=args.log_requests,
            delay=args.delay_ms / 1000.0,
        )
    except OSError as exc:
        raise RoboLabError(
            f"cannot listen on {args.host}:{port}: {exc.strerror or exc}; is another server "
            "running there? Choose another --port"
        ) from None
    except KeyboardInterrupt:
        return 0
    return 0


def _check_adaptive(args: argparse.Namespace) -> None:
    from robolab_ms.eval.runner import ADAPTIVE_MIN_EPISODES

    if args.episodes_adaptive is not None and args.episodes_adaptive < ADAPTIVE_MIN_EPISODES:
        raise RoboLabError(
            f"--episodes-adaptive must be at least {ADAPTIVE_MIN_EPISODES}, got {args.episodes_adaptive}"
        )
    if not 0 < args.ci_width < 1:
        raise RoboLabError(
            f"--ci-width must be between 0 and 1 (a width of the success-rate interval), got {args.ci_width}"
        )


def _record_options(args: argparse.Namespace):
    from robolab_ms.eval.recording import RecordOptions

    return RecordOptions(trajectory=args.record or args.record_images, images=args.record_images, video=args.video)


def _add_record_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("episodes and recordings")
    group.add_argument(
        "--episodes-adaptive",
        type=int,
        default=None,
        metavar="MAX_N",
        help="instead of --episodes: per task, add episodes until the 95 %% interval of the success "
        "rate is at most --ci-width wide, at least 10 and at most MAX_N (RoboLab's presets: 50 with "
        "0.30, 200 with 0.14, 400 with 0.10)",
    )
    group.add_argument(
        "--ci-width",
        type=float,
        default=0.14,
        metavar="W",
        help="interval width that ends adaptive sampling (default: 0.14)",
    )
    group.add_argument(
        "--record",
        action="store_true",
        help="keep each episode as a ManiSkill trajectory file "
        "(OUT/recordings/<Task>/*.h5 + .json: actions, env states, proprio), replayable with "
        "`robolab replay` and ManiSkill's replay_trajectory",
    )
    group.add_argument(
        "--record-images", action="store_true", help="--record, with the policy cameras' images in the trajectory files"
    )
    group.add_argument(
        "--video",
        action="store_true",
        help="write an mp4 per episode (OUT/videos/<Task>/): policy "
        "cameras and the wide video camera, with instruction, step, score and events",
    )


def _cmd_replay(args: argparse.Namespace) -> int:
    from robolab_ms.eval.recording import find_recordings, replay_recording

    files = find_recordings(Path(args.path))
    failed = 0
    for file in files:
        report = replay_recording(file, tolerance=args.tolerance)
        print(report.line())
        failed += not report.matches
    print(
        f"{len(files) - failed}/{len(files)} recording(s) reproduced"
        + (" exactly" if args.tolerance == 0 else f" within {args.tolerance:g}")
    )
    return 1 if failed else 0


def _cmd_export_lerobot(args: argparse.Namespace) -> int:
    from robolab_ms.eval.export_lerobot import export_lerobot

    report = export_lerobot(
        Path(args.run_dir),
        Path(args.out_dir),
        success_only=args.success_only,
        tasks=args.task,
        videos=not args.no_videos,
    )
    for reason in report.skipped:
        print(f"skipped {reason}", file=sys.stderr)
    print(f"LeRobot dataset (v3.0): {report.line()}")
    return 0


def _add_export_commands(commands) -> None:
    export = commands.add_parser(
        "export",
        help="write recorded episodes in another format (LeRobot dataset)",
        description="Convert the episodes recorded with `robolab eval --record` "
        "(--record-images for camera videos) into another format.",
    )
    formats = export.add_subparsers(dest="export_format", required=True, metavar="FORMAT")
    lerobot = formats.add_parser(
        "lerobot",
        help="a LeRobot dataset, v3.0 layout (meta/, data/ parquet, one mp4 per camera)",
        description="Write the recordings of RUN_DIR as a LeRobot dataset in LeRobot's v3.0 layout in OUT_DIR (new "
        "or empty): meta/info.json (fps 15), meta/stats.json, meta/tasks.parquet, meta/episodes/ (with success "
        "and score), data/ (observation.state = 7 joints + gripper, action, timestamp, next.done, ...) and one "
        "H.264 video per camera under videos/. Errored episodes are left out. See docs/scaling.md.",
    )
    lerobot.add_argument("run_dir", metavar="RUN_DIR", help="a results folder written with --record or --record-images")
    lerobot.add_argument("out_dir", metavar="OUT_DIR", help="the dataset folder to write (new or empty)")
    lerobot.add_argument("--success-only", action="store_true", help="only the successful episodes")
    lerobot.add_argument("--task", nargs="+", metavar="TASK", help="only these tasks (default: all recorded)")
    lerobot.add_argument("--no-videos", action="store_true", help="leave the camera images out")
    lerobot.set_defaults(run=_cmd_export_lerobot)


def _add_generate_commands(commands) -> None:
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
        "a physics settle (no object may move more than 2 cm in 300 steps) checks it. Failures go back to the model "
        "for at most --rounds rounds. Writes FILE.yaml, its preview FILE.png and FILE.transcript.json.",
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


def _cmd_scene_export(args: argparse.Namespace) -> int:
    from robolab_ms.scene import load_scene, read_scene
    from robolab_ms.scene.usd_export import export_scene

    scene = Path(args.scene)
    spec = read_scene(scene) if scene.suffix == ".yaml" and scene.is_file() else load_scene(args.scene)
    report = export_scene(spec, Path(args.usd))
    print(f"USD stage: {report.line()}; it opens without composition errors and passes USD's checks")
    return 0


def _cmd_scene_import(args: argparse.Namespace) -> int:
    from robolab_ms.scene.usd_import import import_scene

    usd = Path(args.usd)
    out = Path(args.out) if args.out else usd.with_suffix(".yaml")
    report = import_scene(usd, out, Path(args.map) if args.map else None)
    for note in report.notes:
        print(f"note: {note}")
    print(f"scene file: {report.line()}; the scene loader reads it")
    return 0


def _add_scene_commands(commands, content: argparse.ArgumentParser) -> None:
    scene = commands.add_parser(
        "scene",
        help="write a scene as USD, or read a USD layout into a scene file",
        description="Scenes in USD (usd-core): see docs/usd.md.",
    )
    actions = scene.add_subparsers(dest="scene_command", required=True, metavar="ACTION")
    export = actions.add_parser(
        "export",
        parents=[content],
        help="write a scene as a USD stage (geometry, poses, UsdPhysics bodies)",
        description="Write SCENE as FILE.usda: the table and robot stand as static colliders, one Xform per object "
        "named after it with xformOp:translate and xformOp:orient, RigidBodyAPI and MassAPI (fixtures kinematic), "
        "referencing one asset per catalog object in an assets/ folder beside FILE (primitives, or the visual "
        "meshes with textures and the convex collision pieces). Z up, metres. The stage is opened and checked "
        "with USD's validators before the command succeeds.",
    )
    export.add_argument("scene", metavar="SCENE", help="a scene name (as in a task's `scene:`) or a scene file")
    export.add_argument("--usd", required=True, metavar="FILE.usda", help="the USD file to write (.usda, .usd, .usdc)")
    export.set_defaults(run=_cmd_scene_export)
    load = actions.add_parser(
        "import",
        parents=[content],
        help="read a USD layout (bodies, poses, assets) into a scene file",
        description="Read the bodies of FILE (prims with robolab:catalog, a RigidBodyAPI, a reference or payload, "
        "or a --map entry), map each to a catalog object (robolab:catalog, --map, or the referenced file's name), "
        "convert its world pose to x, y, yaw and tilt, find what it rests on, write the scene file and read it "
        "back with the scene loader.",
    )
    load.add_argument("usd", metavar="FILE.usda", help="a USD file (.usda, .usd, .usdc)")
    load.add_argument(
        "--out",
        metavar="FILE.yaml",
        help="the scene file to write; its name is the scene's (default: FILE with .yaml, beside it)",
    )
    load.add_argument(
        "--map",
        metavar="MAP.yaml",
        help="YAML mapping of USD asset paths, file names or prim names "
        "(patterns such as 'Banana*' allowed) to catalog names, null to leave a prim out",
    )
    load.set_defaults(run=_cmd_scene_import)


def _catalog_file(args: argparse.Namespace) -> Path:
    from robolab_ms.content import content_dir

    return Path(args.catalog) if args.catalog else content_dir("assets") / "catalog.yaml"


def _cmd_catalog_build(args: argparse.Namespace) -> int:
    from robolab_ms.catalog.build import build_catalog

    file = _catalog_file(args)
    report = build_catalog(file, names=args.objects, force=args.force)
    print(
        f"{len(report.built)} built, {len(report.skipped)} up to date; "
        f"{file} {'rewritten' if report.catalog_changed else 'unchanged'}"
    )
    return 0


def _catalog_of(args: argparse.Namespace):
    """The catalog named by --catalog, else the shipped one joined by the user content folders' catalogs."""
    from robolab_ms.catalog import load_catalog, read_catalog

    return read_catalog(Path(args.catalog)) if args.catalog else load_catalog()


def _cmd_catalog_check(args: argparse.Namespace) -> int:
    from robolab_ms.catalog.check import check_catalog

    catalog = _catalog_of(args)
    for name in args.objects or []:
        catalog[name]  # unknown names fail here, with suggestions
    results = check_catalog(catalog, args.objects, render=not args.no_render)
    failed = [result.name for result in results if not result.passed]
    print(
        f"{len(results) - len(failed)}/{len(results)} objects passed"
        + (f"; failed: {', '.join(failed)}" if failed else "")
    )
    return 1 if failed else 0


def _cmd_catalog_sheet(args: argparse.Namespace) -> int:
    from robolab_ms.catalog.check import contact_sheet

    out = contact_sheet(_catalog_of(args), Path(args.out), args.objects, tile=args.tile)
    print(f"contact sheet: {out}")
    return 0


GRASP_CLEARANCE = 0.005  # m: an object "fits" the open gripper with at least this much room on each side


def _cmd_catalog_list(args: argparse.Namespace) -> int:
    from robolab_ms.catalog import DROID_GRIPPER_OPENING as GRIPPER_OPENING
    from robolab_ms.catalog import SHAPE_KINDS, narrowest_width

    catalog = _catalog_of(args)
    rows = [("object", "class", "shape", "size x y z (cm)", "grasp (cm)", "fits", "colours", "mass (kg)", "source")]
    for name in catalog.names():
        entry = catalog[name]
        if entry.is_procedural:
            kind = entry.source["generator"]
        elif entry.source["kind"] == "file":  # added with `robolab catalog add`: the folder it lies in
            kind = f"file in {entry.folder}"
        else:
            kind = entry.source["package"]
        size = " x ".join(f"{d * 100:.1f}" for d in (entry.recorded_dimensions or entry.dimensions))
        width = narrowest_width(entry)
        fits = "yes" if width <= GRIPPER_OPENING - 2 * GRASP_CLEARANCE else "tight" if width < GRIPPER_OPENING else "no"
        rows.append(
            (
                name,
                entry.object_class,
                entry.shape,
                size,
                f"{width * 100:.1f}",
                fits,
                ",".join(entry.colors) or "-",
                f"{entry.mass:.3f}",
                kind,
            )
        )
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        print("  ".join(cell.ljust(width) for cell, width in zip(row, widths)).rstrip())
    print(
        f"\n{len(catalog)} object(s): {_shape_counts(catalog)}. shape: how the object's form was made ("
        + "; ".join(f"{kind}: {meaning}" for kind, meaning in SHAPE_KINDS.items())
        + "). grasp: the narrowest horizontal width as the object stands; fits: whether "
        f"that is under the DROID gripper's {GRIPPER_OPENING * 1000:.0f} mm opening with "
        f"{GRASP_CLEARANCE * 1000:.0f} mm to spare on each side (yes), under it (tight) or not (no; a thin part such "
        "as a handle or rim may still be graspable)"
    )
    return 0


def _shape_counts(catalog) -> str:
    """How many objects have each shape kind, e.g. '41 scanned, 35 modelled, 223 primitive'."""
    from robolab_ms.catalog import SHAPE_KINDS

    counts = {kind: 0 for kind in SHAPE_KINDS}
    for entry in catalog.objects.values():
        counts[entry.shape] += 1
    return ", ".join(f"{count} {kind}" for kind, count in counts.items())


def _cmd_catalog_add(args: argparse.Namespace) -> int:
    from robolab_ms.catalog.add import add_object, describe

    result = add_object(
        args.mesh,
        args.name,
        args.object_class,
        content=args.target,
        mass=args.mass,
        scale=args.scale,
        up=args.up,
        description=args.description,
        colors=args.colors,
        friction=tuple(args.friction),
        origin=args.origin,
        license=args.license,
        allow_open=args.allow_open,
        replace=args.replace,
        sheet=not args.no_sheet,
        shape=args.shape,
    )
    print(describe(result))
    return 0


def _add_catalog_add_command(actions) -> None:
    from robolab_ms.catalog import COLOR_NAMES, OBJECT_CLASSES, SHAPE_KINDS
    from robolab_ms.catalog.add import (
        CLASS_DENSITY,
        DEFAULT_CONTENT,
        DEFAULT_FRICTION,
        MAX_SIZE,
        MIN_SIZE,
        UP_ROTATIONS,
    )
    from robolab_ms.content import CONTENT_ENV, USER_CATALOG

    add = actions.add_parser(
        "add",
        help="add a mesh file of your own (OBJ, GLB, STL) to a content folder's catalog",
        description="Measure a mesh file, check it (it must hold triangles, have a thickness, be "
        f"{MIN_SIZE * 1000:g} mm to {MAX_SIZE:g} m across and, after trimesh's repairs, be a closed surface), copy it "
        f"into DIR/assets/meshes/NAME/, write its entry into DIR/{USER_CATALOG} with source.origin and license "
        "marked TO FILL IN, make its collision by coacd convex decomposition into DIR/assets/collision/NAME.obj "
        "(coacd's pieces are cached by the mesh's content), check it in SAPIEN as `robolab catalog check` does "
        "(nothing is kept when it fails) and render the folder's objects into DIR/assets/contact_sheet.png. DIR is "
        f"--content DIR, else the first folder of ${CONTENT_ENV}, else ./{DEFAULT_CONTENT}. Scenes then name the "
        f"object as `asset: NAME` when DIR is in ${CONTENT_ENV} or given with --content. See docs/catalog.md.",
    )
    add.add_argument("mesh", metavar="MESH", help="the mesh file: .obj (with its .mtl and textures), .glb or .stl")
    add.add_argument("--name", required=True, help="the catalog name: letters, digits and underscores, e.g. red_vase")
    add.add_argument(
        "--class", dest="object_class", required=True, metavar="CLASS", help=f"one of {', '.join(OBJECT_CLASSES)}"
    )
    add.add_argument(
        "--content",
        dest="target",
        metavar="DIR",
        help=f"the content folder to write to (created when missing; default: the first folder of "
        f"${CONTENT_ENV}, else ./{DEFAULT_CONTENT})",
    )
    add.add_argument(
        "--mass",
        type=float,
        metavar="KG",
        help="mass in kg (default: the class's density, the median of the shipped objects of that class "
        f"({min(CLASS_DENSITY.values()):g} to {max(CLASS_DENSITY.values()):g} kg/m^3), times the volume "
        "of the collision pieces)",
    )
    add.add_argument(
        "--scale",
        type=float,
        default=1.0,
        help="metres per unit of the file (default 1; millimetres: 0.001, centimetres: 0.01, inches: 0.0254)",
    )
    add.add_argument(
        "--up",
        choices=list(UP_ROTATIONS),
        help="the file's axis that points up (default: y for .glb, as glTF specifies; z otherwise)",
    )
    add.add_argument("--description", help="one sentence (default: 'A NAME (added from FILE).')")
    add.add_argument(
        "--colors",
        nargs="+",
        metavar="COLOUR",
        help="colour names, the first for untextured meshes (default: the nearest to the mesh's own "
        f"colour, else grey); one of {', '.join(COLOR_NAMES)}",
    )
    add.add_argument(
        "--friction",
        nargs=2,
        type=float,
        default=list(DEFAULT_FRICTION),
        metavar=("STATIC", "DYNAMIC"),
        help=f"friction coefficients (default {DEFAULT_FRICTION[0]:g} {DEFAULT_FRICTION[1]:g})",
    )
    add.add_argument(
        "--shape",
        choices=list(SHAPE_KINDS),
        default="modelled",
        help="how the mesh's form was made: scanned (a 3D scan of a real object), modelled (default) or primitive",
    )
    add.add_argument("--origin", help="where the mesh comes from (web address, author); default: marked TO FILL IN")
    add.add_argument("--license", help="the mesh's licence, e.g. CC-BY-4.0; default: marked TO FILL IN")
    add.add_argument(
        "--allow-open",
        action="store_true",
        help="accept a surface that is not closed (coacd's preprocessing closes it for the collision)",
    )
    add.add_argument("--replace", action="store_true", help="replace an object of that name in DIR's catalog")
    add.add_argument("--no-sheet", action="store_true", help="do not render the contact sheet")
    add.set_defaults(run=_cmd_catalog_add)


def _add_catalog_commands(commands) -> None:
    from robolab_ms.content import CONTENT_ENV

    catalog = commands.add_parser(
        "catalog",
        help="build, check, list and picture the object catalog; add meshes",
        description="The object catalog (assets/catalog.yaml, joined by the catalogs of the "
        "user content folders) and its derived files.",
    )
    actions = catalog.add_subparsers(dest="catalog_command", required=True, metavar="ACTION")
    build = actions.add_parser(
        "build",
        help="derive transforms, dimensions and collision hulls from the installed "
        "asset packages (idempotent; coacd runs only for changed objects)",
    )
    build.add_argument("--force", action="store_true", help="rebuild even objects that are up to date")
    build.set_defaults(run=_cmd_catalog_build)
    check = actions.add_parser(
        "check",
        help="load every object in SAPIEN and check rest, size, density, "
        "rendering and (containers) holding a small object",
    )
    check.add_argument("--no-render", action="store_true", help="skip the rendering check")
    check.set_defaults(run=_cmd_catalog_check)
    sheet = actions.add_parser("sheet", help="render a labelled grid of the objects to a PNG")
    sheet.add_argument("--out", default="docs/images/contact_sheet.png", help="output PNG")
    sheet.add_argument("--tile", type=int, default=112, help="tile size in pixels (default 112)")
    sheet.set_defaults(run=_cmd_catalog_sheet)
    listing = actions.add_parser(
        "list", help="list the objects with class, size, graspable width, colours, mass and source"
    )
    listing.set_defaults(run=_cmd_catalog_list)
    build.add_argument("--catalog", help="catalog file (default: the shipped assets/catalog.yaml)")
    for action in (check, sheet, listing):
        action.add_argument(
            "--catalog",
            help="one catalog file (default: the shipped assets/catalog.yaml and the "
            "assets/catalog.yaml of each content folder)",
        )
        action.add_argument(
            "--content",
            action="append",
            default=[],
            metavar="DIR",
            help=f"a content folder whose catalog objects (DIR/assets/catalog.yaml) join the shipped "
            f"ones, after those of ${CONTENT_ENV}; may be given more than once",
        )
    for action in (build, check, sheet):
        action.add_argument("--objects", nargs="+", metavar="NAME", help="only these objects (default: all)")
    _add_catalog_add_command(actions)


def _cmd_validate(args: argparse.Namespace) -> int:
    from robolab_ms.eval.validate import REPORT_CSV, validate_parallel, validate_task, write_report
    from robolab_ms.tasks.spec import task_names

    if args.seeds < 1:
        raise RoboLabError(f"--seeds must be at least 1, got {args.seeds}")
    if args.seed < 0:
        raise RoboLabError(f"--seed must be 0 or more (the seeds are --seed, --seed+1, ...), got {args.seed}")
    if args.workers < 1:
        raise RoboLabError(f"--workers must be at least 1, got {args.workers}")
    if not args.all and not args.task:
        raise RoboLabError("name the tasks to validate with --task NAME ..., or use --all")
    tasks = task_names() if args.all else list(_task_arguments(args.task))
    from robolab_ms.errors import make_folder

    out = make_folder(args.out, "--out")
    rows = []
    try:
        if args.workers > 1:
            rows = validate_parallel(
                tasks,
                args.seeds,
                out,
                args.seed,
                args.workers,
                show_progress=not args.quiet,
                variations=_vary_text(args.vary),
            )
        else:
            for task in tasks:
                rows.append(
                    validate_task(
                        task, args.seeds, out, args.seed, show_progress=not args.quiet, variations=_vary_text(args.vary)
                    )
                )
                write_report(rows, out)  # after every task: an interrupted run keeps what it checked
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: finished episodes are kept in {out / 'episodes.jsonl'}; run the same command again "
            "to resume",
            file=sys.stderr,
        )
        return 130
    report = write_report(rows, out)
    print(report.read_text(), end="")
    for row in rows:
        if row.oracle_failures:
            print(f"why the oracle failed {row.task}: {row.oracle_failures}")
    print(f"report: {report} (and {out / REPORT_CSV}); episodes: {out / 'episodes.jsonl'}")
    failed = [row.task for row in rows if not row.passed]
    if failed:
        print(f"robolab: {len(failed)} task(s) failed validation: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="robolab",
        description="RoboLab benchmark on ManiSkill3: list tasks, evaluate policies, validate tasks, build and check the object catalog.",
        epilog="Environments are also usable directly: gym.make('RoboLab-<Task>-v1') after importing mani_skill.envs.",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    from robolab_ms.content import CONTENT_ENV

    content = argparse.ArgumentParser(add_help=False)
    content.add_argument(
        "--content",
        action="append",
        default=[],
        metavar="DIR",
        help=f"a folder of your own tasks and scenes (DIR/task_specs/, DIR/scene_builders/), added "
        f"after those of ${CONTENT_ENV}; may be given more than once",
    )
    task_help = (
        "task name(s) as in `robolab list`, e.g. BananaInBowl, or task file(s), e.g. my_tasks/T.yaml (its "
        "scene is found next to it, in a sibling scene_builders/ folder, or by name)"
    )

    listing = commands.add_parser("list", help="list the tasks with their attributes and difficulty", parents=[content])
    listing.add_argument("--task", nargs="+", metavar="TASK", help=task_help + " (default: every known task)")
    listing.add_argument(
        "--summary",
        action="store_true",
        help="print the benchmark's totals next to RoboLab-120's, with the difference: tasks, "
        "scenes, tasks per attribute, competency axis, difficulty and episode length, and objects "
        "per task (the objects of the task's scene a policy sees: targets, distractors, containers "
        "and fixtures, not the table or the robot's stand); then RoboLab's tasks still missing and "
        "each task whose facts differ from RoboLab's. Filters apply to both sides, RoboLab's by its "
        "own attributes, difficulty and scene",
    )
    listing.add_argument(
        "--format",
        choices=("text", "csv", "markdown"),
        default="text",
        help="with --summary: aligned text (default), CSV or Markdown tables",
    )
    _add_task_filters(listing)
    listing.set_defaults(run=_cmd_list)

    evaluate = commands.add_parser(
        "eval",
        parents=[content],
        help="evaluate a policy on tasks and write results",
        description="Run a policy for N episodes (seeds first_seed .. first_seed+N-1) on each task. Each finished "
        "episode is appended to OUT/episodes.jsonl at once; rerunning the same command skips finished episodes. "
        "OUT/summary.csv and OUT/summary.md (rewritten after each task) hold success rate (95% interval), score, "
        "Score(fail), trajectory metrics and event counts; OUT/tasks/<Task>.csv lists every episode of a task.",
    )
    evaluate.add_argument(
        "--policy",
        default="random",
        help="random, hold, oracle, replay, openpi, gr00t, or module.path:factory (default: random)",
    )
    evaluate.add_argument(
        "--policy-name",
        metavar="NAME",
        help="file the results under NAME instead of the policy's own name, e.g. pi05 and pi0 for "
        "two openpi servers, so `robolab analyze` and `leaderboard` tell them apart",
    )
    evaluate.add_argument("--task", nargs="+", metavar="TASK", help=task_help + "; `all` for every task")
    evaluate.add_argument("--episodes", type=int, default=10, help="episodes per task (default: 10)")
    evaluate.add_argument("--out", default="results/latest", help="results folder (default: results/latest)")
    evaluate.add_argument("--instruction", default="default", help="instruction variant: default, vague or specific")
    evaluate.add_argument("--robot", default=None, help="robot: droid (default; Panda + Robotiq 2F-85), panda or so100")
    evaluate.add_argument("--seed", type=int, default=0, help="first episode seed (default: 0)")
    evaluate.add_argument(
        "--max-steps",
        type=int,
        default=None,
        help="cut episodes after this many control steps (default: the task's length)",
    )
    evaluate.add_argument("--quiet", action="store_true", help="no progress bar")
    evaluate.add_argument(
        "--retry-errors",
        action="store_true",
        help="run episodes again whose result is errored (a plain rerun skips them)",
    )
    evaluate.add_argument(
        "--save-actions",
        action="store_true",
        help="keep each episode's executed actions in OUT/actions/ (for --policy replay)",
    )
    evaluate.add_argument(
        "--reconnect-seconds",
        type=float,
        default=30.0,
        metavar="SECONDS",
        help="after a lost policy server, keep trying to reconnect this long (default: 30)",
    )
    _add_policy_options(evaluate, "127.0.0.1")
    _add_task_filters(evaluate)
    _add_record_options(evaluate)
    varying = evaluate.add_argument_group(
        "domain randomization",
        "each episode's parameters are drawn from its seed and recorded on its result line (docs/variations.md)",
    )
    varying.add_argument(
        "--vary",
        action="append",
        metavar="SETTINGS",
        help="axes to vary: lighting, background, table, camera, objects, robot, noise, distractors; "
        "AXIS=VALUE sets a condition or range (objects=0.2, lighting=dim, camera=wrist), "
        "AXIS.PARAM=VALUE one parameter (lighting.intensity=0.5:2); comma-separated, repeatable",
    )
    varying.add_argument(
        "--suite",
        metavar="NAME[:COND/COND]",
        help="run a named suite (lighting, background, table, camera, objects; see `robolab "
        "suites`), one results folder OUT/<condition> per condition, and write OUT/suite.md",
    )
    scale = evaluate.add_argument_group(
        "parallel and distributed runs",
        "Every worker has its own policy instance and environment; only this process writes OUT (docs/scaling.md)",
    )
    scale.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="run episodes in N processes on this machine (default: 1, in this process); with --ray: "
        "N Ray actors (default: one per CPU of the cluster)",
    )
    scale.add_argument(
        "--ray",
        metavar="ADDRESS",
        default=None,
        help="spread episodes over a Ray cluster: its address (host:6379, ray://host:10001), auto "
        "(the cluster this machine belongs to), or local (start Ray on this machine for this run)",
    )
    evaluate.set_defaults(run=_cmd_eval)

    replay = commands.add_parser(
        "replay",
        help="replay recorded episodes and check that they come out the same",
        description="Replay episodes recorded with `robolab eval --record`: rebuild each episode's environment "
        "from its .json, reset with its seed, step its actions, and compare the environment state after every "
        "step and the final success and score with the recording. Exits with status 1 when one differs.",
    )
    replay.add_argument("path", metavar="PATH", help="a recording (.h5) or a results folder (all its recordings)")
    replay.add_argument(
        "--tolerance",
        type=float,
        default=0.0,
        help="largest state difference still counted as the same (default: 0, bit-identical)",
    )
    replay.set_defaults(run=_cmd_replay)
    _add_export_commands(commands)
    _add_generate_commands(commands)

    serving = commands.add_parser(
        "serve",
        help="serve one of our policies over openpi's (or GR00T's) protocol",
        description="Serve a policy (random, hold, replay, module.path:factory) as a policy server, so the remote "
        "path of `robolab eval --policy openpi` (or gr00t) can be checked on this machine. Several clients at "
        "once, each with its own policy instance, seeded from the episode seed each client sends.",
    )
    serving.add_argument("--policy", default="random", help="the policy to serve (default: random)")
    serving.add_argument(
        "--protocol", choices=("openpi", "gr00t"), default="openpi", help="openpi websocket (default) or GR00T ZMQ"
    )
    serving.add_argument(
        "--action-horizon", type=int, default=10, metavar="H", help="actions per reply chunk (default: 10, as pi0)"
    )
    serving.add_argument("--log-requests", action="store_true", help="print one line per answered request")
    serving.add_argument(
        "--delay-ms",
        type=float,
        default=0.0,
        metavar="MS",
        help="answer no sooner than MS after each request came in: the served policy stands in "
        "for a slower one (try `robolab eval --realtime` against it; default: 0)",
    )
    _add_policy_options(serving, "0.0.0.0", client=False)
    serving.set_defaults(run=_cmd_serve)
    _add_catalog_commands(commands)
    _add_scene_commands(commands, content)

    validate = commands.add_parser(
        "validate",
        parents=[content],
        help="check tasks: stable at rest, not solved at reset, not solved by chance, solved by the oracle",
        description="For each task over SEEDS seeds: the largest object drift over 300 physics steps at rest "
        "(max 2 cm), success right after reset (must be none), the random policy's success rate (max 10%) and "
        "the oracle's (min 90%) with its time per episode. Writes OUT/validation.csv and OUT/validation.md, the "
        "episodes to OUT/episodes.jsonl (a rerun resumes), and exits with status 1 when a task fails a check. "
        "With --workers N the checks and episodes of all tasks run in N processes (docs/scaling.md).",
    )
    validate.add_argument("--task", nargs="+", metavar="TASK", help=task_help)
    validate.add_argument("--all", action="store_true", help="validate every task")
    validate.add_argument("--seeds", type=int, default=10, help="seeds per task (default: 10)")
    validate.add_argument("--seed", type=int, default=0, help="first seed (default: 0)")
    validate.add_argument("--out", default="results/validate", help="results folder (default: results/validate)")
    validate.add_argument("--quiet", action="store_true", help="no progress bars")
    validate.add_argument(
        "--workers",
        type=int,
        default=1,
        metavar="N",
        help="run the rest checks and the random and oracle episodes of all tasks in N worker "
        "processes (as `robolab eval --workers`); this process alone writes OUT, the report rows "
        "stay in task order and the results are those of one process (default: 1, in this "
        "process, task after task)",
    )
    validate.add_argument(
        "--vary",
        action="append",
        metavar="SETTINGS",
        help="validate under domain randomization, as `robolab eval --vary` (e.g. objects=0.2)",
    )
    validate.set_defaults(run=_cmd_validate)

    from robolab_ms import fidelity

    listing_suites = commands.add_parser(
        "suites",
        help="list the named variation suites and the --vary axes",
        description="The named suites of RoboLab's robustness experiments "
        "(conditions and their --vary settings) and every variation axis.",
    )
    listing_suites.set_defaults(run=_cmd_suites)

    render_check = commands.add_parser(
        "render-check",
        help="name the rendering device and measure how DROID-like every scene looks",
        description="Renders every scene with DROID's cameras and prints the share of objects with an image "
        "texture (target >= 90 %), the share of external-camera pixels showing the grid ground or empty "
        "background (target 0 %) and whether shadows are on; exits 1 when a target is missed. Then counts the objects "
        "the tasks move (and all scene objects) whose catalog shape is scanned or modelled, not primitives (goal 60 %, "
        "reported only).",
    )
    fidelity.add_arguments(render_check)
    render_check.set_defaults(run=fidelity.run)

    from robolab_ms.analysis import analyze

    analyzing = commands.add_parser(
        "analyze",
        parents=[content],
        help="tables, plots and paired comparisons of results folders",
        description="Success (95 % Beta interval), Score, Score(fail), time to success, SPARC, path length, speed "
        "and event rates per policy, by task, competency axis, attribute, difficulty, scene, instruction variant, "
        "number of objects, episode length, wrong objects grasped or any recorded field; --compare A B: paired "
        "comparison on matched episodes (exact McNemar per task, bootstrap over tasks). See docs/analysis.md.",
    )
    analyze.add_arguments(analyzing)
    analyzing.set_defaults(run=analyze.run)

    from robolab_ms.analysis import leaderboard

    ranking = commands.add_parser(
        "leaderboard",
        parents=[content],
        help="write a static leaderboard site (HTML + Markdown) from results",
        description="Rank the policies of the results folders by overall success (95 % Beta interval; ties by "
        "score) with columns per competency axis and difficulty, one page per task with videos, a Markdown copy, "
        "and with --real-world the sim-to-real correlation. Open SITE_DIR/index.html; no server needed.",
    )
    leaderboard.add_arguments(ranking)
    ranking.set_defaults(run=leaderboard.run)

    from robolab_ms.analysis import sensitivity

    sensitive = commands.add_parser(
        "sensitivity",
        parents=[content],
        help="which varied parameters move a policy's outcome (sbi's MNPE / NPE)",
        description="RoboLab's sensitivity analysis of episodes run with --vary: a neural posterior (MNPE with "
        "categorical parameters, else NPE) of the normalised parameters given the outcomes, sampled at an outcome "
        "(default success = 1); parameters ranked by how far their posterior moves from the prior; marginal and "
        "pairwise plots. See docs/analysis.md.",
    )
    sensitivity.add_arguments(sensitive)
    sensitive.set_defaults(run=sensitivity.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        from robolab_ms.content import add_content_root

        for folder in getattr(args, "content", None) or []:
            add_content_root(folder)
        code = args.run(args)
        sys.stdout.flush()  # here, so that a reader gone away (`robolab list | head`) is caught below
        return code
    except RoboLabError as error:
        print(f"robolab: error: {error}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader of stdout stopped reading: nothing more to say to it
        _stdout_to_devnull()
        return 1


def _stdout_to_devnull() -> None:
    """Point stdout at the null device, so that flushing it at exit does not fail on a closed pipe again."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout without a file descriptor (captured): nothing to redirect
        pass


if __name__ == "__main__":
    sys.exit(main())
