"""`robolab catalog`: build, check, list and picture the object catalog, and add meshes of one's own."""

from __future__ import annotations

import argparse
from pathlib import Path

from robolab_ms.cli.common import print_aligned


def add_catalog_command(commands) -> None:
    """Add `robolab catalog` to the commands."""
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


def _catalog_file(args: argparse.Namespace) -> Path:
    """The catalog file named by --catalog, else the shipped one."""
    from robolab_ms.catalog import shipped_catalog_file

    return Path(args.catalog) if args.catalog else shipped_catalog_file()


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


def _cmd_catalog_list(args: argparse.Namespace) -> int:
    from robolab_ms.catalog.listing import listing_note, listing_rows

    catalog = _catalog_of(args)
    print_aligned(listing_rows(catalog))
    print(f"\n{listing_note(catalog)}")
    return 0


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
