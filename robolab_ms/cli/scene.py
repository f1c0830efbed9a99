"""`robolab scene` (a scene as USD, a USD layout as a scene file) and `robolab render-check` (how DROID-like the
scenes look)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_scene_command(commands, content: argparse.ArgumentParser) -> None:
    """Add `robolab scene` to the commands."""
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


def add_render_check_command(commands) -> None:
    """Add `robolab render-check` to the commands."""
    from robolab_ms import fidelity

    render_check = commands.add_parser(
        "render-check",
        help="name the rendering device and measure how DROID-like every scene looks",
        description="Renders every scene with DROID's cameras and prints the share of objects with an image "
        "texture (target >= 90 %), the share of external-camera pixels showing the grid ground or empty "
        "background (target 0 %) and whether shadows are on; exits 1 when a target is missed.",
    )
    fidelity.add_arguments(render_check)
    render_check.set_defaults(run=fidelity.run)


def _cmd_scene_export(args: argparse.Namespace) -> int:
    from robolab_ms.scene import load_scene_or_file
    from robolab_ms.scene.usd_export import export_scene

    report = export_scene(load_scene_or_file(args.scene), Path(args.usd))
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
