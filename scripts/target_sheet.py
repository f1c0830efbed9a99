"""The before / after contact sheet of RoboLab-120's task targets (docs/fidelity.md, "Real shapes"): every catalog
object that plays a task target, rendered alone as `robolab catalog sheet` renders it, beside the object that played
the same scene placements before the shape work (the catalog and scenes at 75758d3).

    before=$(mktemp -d) && git archive 75758d3 | tar -x -C "$before"
    PYTHONPATH="$before" .venv/bin/python scripts/target_sheet.py --tag before   # old catalog and scenes
    .venv/bin/python scripts/target_sheet.py --tag after
    .venv/bin/python scripts/target_sheet.py --sheet

`--tag` writes TAG/targets.json (scene and placement -> catalog object, for every object a task's success condition
names) and one tile per object to --out (default results/target_sheet); `--sheet` pairs the two mappings and writes
docs/images/fidelity/task_targets.png, one pair of tiles per distinct change, with how many placements it covers.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

from PIL import Image, ImageDraw, ImageFont

ROOT = Path(__file__).resolve().parents[1]
SHEET = ROOT / "docs" / "images" / "fidelity" / "task_targets.png"
OLD_KINDS = {"procedural": (120, 120, 120), "packaged": (150, 110, 40)}  # an old catalog's tags (no shape field)


def task_targets() -> dict[str, str]:
    """'scene/placement' -> catalog object, for every scene object a task's success condition names."""
    from robolab_ms.tasks.spec import load_all_tasks

    targets = {}
    for task in load_all_tasks():
        for condition in task.success:
            for name in condition.objects:
                targets[f"{task.scene.name}/{name}"] = task.scene.placement(name).asset
    return dict(sorted(targets.items()))


def shape_kind(entry) -> str:
    """The entry's shape kind; in an old catalog without the field, `procedural` or `packaged` (a mesh)."""
    shape = getattr(entry, "shape", None)
    if shape:
        return shape
    return "procedural" if entry.source.get("kind") == "procedural" else "packaged"


def render_tiles(tag: str, out: Path, tile: int) -> None:
    from robolab_ms.catalog import load_catalog
    from robolab_ms.catalog.check import render_object

    folder = out / tag
    folder.mkdir(parents=True, exist_ok=True)
    targets = task_targets()
    catalog = load_catalog()
    kinds, sources = {}, {}
    for name in sorted(set(targets.values())):
        rgb, _ = render_object(catalog[name], image_size=tile)
        Image.fromarray(rgb).save(folder / f"{name}.png", optimize=True)
        kinds[name] = shape_kind(catalog[name])
        sources[name] = catalog[name].source.get("kind")
        print(tag, name, kinds[name], flush=True)
    (folder / "targets.json").write_text(json.dumps({"targets": targets, "kinds": kinds, "sources": sources}, indent=1))


def sheet(out: Path, tile: int, columns: int) -> None:
    from robolab_ms.catalog.check import draw_shape_badge

    before = json.loads((out / "before" / "targets.json").read_text())
    after = json.loads((out / "after" / "targets.json").read_text())
    pairs = Counter(
        (before["targets"].get(placement), asset)
        for placement, asset in after["targets"].items()
        if before["targets"].get(placement)
    )

    def same(old: str, new: str) -> bool:  # the same object from the same kind of source (not remodelled)
        return old == new and before["sources"][old] == after["sources"][new]

    # changed objects first (most placements first), then those that stayed
    ordered = sorted(pairs.items(), key=lambda item: (same(*item[0]), -item[1], item[0][1]))
    label = 28
    rows = -(-len(ordered) // columns)
    gap = 8
    width = columns * (2 * tile + gap)
    image = Image.new("RGB", (width, rows * (tile + label) + 20), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default()
    draw.text(
        (4, 4), "each pair: before (75758d3) | after; tag = shape kind; xN = task-target placements", fill=0, font=font
    )
    for index, ((old, new), count) in enumerate(ordered):
        x = (index % columns) * (2 * tile + gap)
        y = 20 + (index // columns) * (tile + label)
        for offset, (tag, name, mapping) in enumerate((("before", old, before), ("after", new, after))):
            picture = Image.open(out / tag / f"{name}.png").convert("RGB").resize((tile, tile))
            image.paste(picture, (x + offset * tile, y))
            kind = mapping["kinds"][name]
            draw_shape_badge(draw, font, (x + offset * tile, y), kind, OLD_KINDS.get(kind))
        caption = new if old == new else f"{old[:17]} > {new[:17]}"
        note = "  (unchanged)" if same(old, new) else "  (remodelled)" if old == new else ""
        draw.text((x + 2, y + tile + 1), caption[:40], fill=(0, 0, 0), font=font)
        draw.text((x + 2, y + tile + 13), f"x{count}{note}", fill=(90, 90, 90), font=font)
    SHEET.parent.mkdir(parents=True, exist_ok=True)
    image.save(SHEET, optimize=True)
    changed = sum(count for (old, new), count in pairs.items() if not same(old, new))
    print(f"contact sheet: {SHEET} ({image.width}x{image.height}); {len(ordered)} pairs, {changed} placements changed")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tag", choices=["before", "after"], help="map the task targets and render their tiles")
    parser.add_argument("--sheet", action="store_true", help="compose the before / after sheet from both tags")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "target_sheet")
    parser.add_argument("--tile", type=int, default=112)
    parser.add_argument("--columns", type=int, default=6)
    args = parser.parse_args()
    if args.tag:
        render_tiles(args.tag, args.out, args.tile)
    if args.sheet:
        sheet(args.out, args.tile, args.columns)


if __name__ == "__main__":
    main()
