"""`robolab replay` (recorded episodes stepped again and compared) and `robolab export` (recordings in another
format)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_replay_command(commands) -> None:
    """Add `robolab replay` to the commands."""
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


def add_export_command(commands) -> None:
    """Add `robolab export` to the commands."""
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
