"""`robolab eval` (a policy on tasks, into a results folder), `robolab suites` (the named variation suites) and
`robolab serve` (one of our policies behind a policy server), with the policy and recording options they share."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from robolab_ms.cli.common import TASK_HELP, add_task_filters, select_tasks, task_arguments, vary_text
from robolab_ms.errors import RoboLabError

if TYPE_CHECKING:
    from robolab_ms.policies import PolicyOptions


def add_eval_command(commands, content: argparse.ArgumentParser) -> None:
    """Add `robolab eval` to the commands."""
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
    evaluate.add_argument("--task", nargs="+", metavar="TASK", help=TASK_HELP + "; `all` for every task")
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
    add_task_filters(evaluate)
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
    select_tasks(args)
    if not args.task:
        raise RoboLabError(
            "name the tasks with --task NAME ... (or --task all), or choose them with --tag, --difficulty or --scene"
        )
    if args.instruction not in INSTRUCTION_VARIANTS:
        raise RoboLabError(f"--instruction must be one of {', '.join(INSTRUCTION_VARIANTS)}")
    policy = make_policy(args.policy, _policy_options(args))
    tasks = task_arguments(args.task)  # unknown names and bad files fail here, with suggestions
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
        variations=vary_text(args.vary),
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


def _run_suite(args: argparse.Namespace, policy, config, out: Path) -> int:
    """Run every condition of `--suite` into OUT/<condition>/ (with any --vary settings first), then write
    OUT/suite.csv and OUT/suite.md."""
    from dataclasses import replace

    from robolab_ms.variations import suite_conditions
    from robolab_ms.variations.suites import suite_summary

    suite, conditions = suite_conditions(args.suite)
    for condition, settings in conditions.items():
        text = vary_text([t for t in (config.variations, settings) if t])
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


def add_suites_command(commands) -> None:
    """Add `robolab suites` to the commands."""
    listing_suites = commands.add_parser(
        "suites",
        help="list the named variation suites and the --vary axes",
        description="The named suites of RoboLab's robustness experiments "
        "(conditions and their --vary settings) and every variation axis.",
    )
    listing_suites.set_defaults(run=_cmd_suites)


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


def add_serve_command(commands) -> None:
    """Add `robolab serve` to the commands."""
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
