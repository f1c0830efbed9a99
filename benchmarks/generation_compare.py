"""Scene generation against RoboLab's grid baseline, on RoboLab's 10 themes x 2 prompts, offline backend.

    PYTHONPATH=. python benchmarks/generation_compare.py [--out results/generation_compare] [--doc docs/generation.md]
        [--images docs/images/generation]

Both methods get the same prompts and the same objects (the offline backend's reading of each prompt) and are judged
by the same relations (that reading's relations) after the same physics settle. Per method: the share of requested
relations that hold after settling, the share of stable scenes (no object moved more than 2 cm in 300 physics
steps), objects placed (in the scene and not fallen off, of those asked for), pairs of objects whose outlines
overlap at placement, and the time per scene (generation, solving and settling; no preview). Writes OUT/rows.csv,
the tables between the markers of the doc's measurement section, and a picture grid of four prompts, both methods.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import tempfile
from pathlib import Path

import yaml
from PIL import Image, ImageDraw

from robolab_ms.catalog import load_catalog
from robolab_ms.generation.offline import OfflineSceneModel
from robolab_ms.generation.proposal import read_proposal
from robolab_ms.generation.scene import generate_scene, render_preview

PROMPTS = Path(__file__).parent / "fixtures" / "generation_prompts.yaml"
BEGIN, END = "<!-- generation_compare:begin -->", "<!-- generation_compare:end -->"
PICTURED = [("kitchen_cabinet", 0), ("craft_station", 0), ("tea_time", 1), ("storage_room", 1)]
TILE = (320, 180)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="results/generation_compare")
    parser.add_argument("--doc", default="docs/generation.md")
    parser.add_argument("--images", default="docs/images/generation")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: the first prompt only, no doc or "
        "picture written; only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    catalog = load_catalog()
    model = OfflineSceneModel(catalog)
    prompts = yaml.safe_load(PROMPTS.read_text(encoding="utf-8"))
    if args.quick:
        theme = next(iter(prompts))
        prompts = {theme: prompts[theme][:1]}
    rows = []
    for theme, texts in prompts.items():
        for number, prompt in enumerate(texts):
            answer, _ = model.ask_json("", [{"role": "user", "content": prompt}])
            requested = [
                r for r in read_proposal(answer, catalog).relations if r.kind not in ("random_yaw", "anywhere")
            ]
            for method in ("solver", "grid"):
                file = out / method / f"{theme}_{number}.yaml"
                file.parent.mkdir(parents=True, exist_ok=True)
                result = generate_scene(
                    prompt, file, model, method=method, render=False, catalog=catalog, requested=requested
                )
                settled = result.settled
                row = {
                    "theme": theme,
                    "prompt": number,
                    "method": method,
                    "accepted": int(result.accepted),
                    "rounds": result.rounds,
                    "requested": len(requested),
                    "satisfied": result.satisfied(),
                    "stable": int(bool(settled and settled.stable)),
                    "asked_objects": len(answer["objects"]),
                    "placed": result.placed(),
                    "collisions": result.collisions,
                    "max_drift_cm": round(max(settled.drift.values()) * 100, 2) if settled else "",
                    "seconds": round(result.seconds, 2),
                    "file": str(file) if result.scene_file else "",
                    "problems": " | ".join(result.problems),
                    "holds": settled.holds.get("requested", []) if settled else [False] * len(requested),
                }
                rows.append(row)
                print(
                    f"{theme}/{number} {method}: {row['satisfied']}/{row['requested']} relations, "
                    f"stable {row['stable']}, placed {row['placed']}/{row['asked_objects']}, "
                    f"collisions {row['collisions']}, {row['seconds']} s",
                    flush=True,
                )
    with (out / "rows.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=[key for key in rows[0] if key != "holds"], extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    tables = render_tables(rows)
    print(tables)
    print(ratio_line(rows))
    if not args.quick:
        write_doc(Path(args.doc), tables)
        picture_grid(rows, prompts, out, Path(args.images))
    return 0


def ratio_line(rows: list[dict]) -> str:
    """Ours against the grid baseline: the shares of requested relations satisfied after settling."""
    shares = {}
    for method in ("solver", "grid"):
        mine = [row for row in rows if row["method"] == method]
        shares[method] = sum(r["satisfied"] for r in mine) / max(sum(r["requested"] for r in mine), 1)
    ratio = f"{shares['solver'] / shares['grid']:.2f}" if shares["grid"] else "inf (the baseline satisfied none)"
    return (
        f"ratio ours / grid baseline, requested relations satisfied after settling: {shares['solver']:.2f} / "
        f"{shares['grid']:.2f} = {ratio}"
    )


def render_tables(rows: list[dict]) -> str:
    lines = [
        "| method | relations satisfied after settling | stable scenes | objects placed | collisions at "
        "placement (pairs per scene) | scenes written | time per scene (s, median) |",
        "|---|---|---|---|---|---|---|",
    ]
    for method in ("solver", "grid"):
        mine = [row for row in rows if row["method"] == method]
        satisfied, requested = sum(r["satisfied"] for r in mine), sum(r["requested"] for r in mine)
        placed, asked = sum(r["placed"] for r in mine), sum(r["asked_objects"] for r in mine)
        stable = sum(r["stable"] for r in mine)
        written = sum(bool(r["file"]) for r in mine)
        collisions = statistics.mean(r["collisions"] for r in mine)
        seconds = statistics.median(r["seconds"] for r in mine)
        label = "ours (`--method solver`)" if method == "solver" else "RoboLab's baseline (`--method grid`)"
        lines.append(
            f"| {label} | {satisfied}/{requested} ({100 * satisfied / requested:.0f} %) | {stable}/{len(mine)} "
            f"({100 * stable / len(mine):.0f} %) | {placed}/{asked} ({100 * placed / asked:.0f} %) | "
            f"{collisions:.2f} | {written}/{len(mine)} | {seconds:.2f} |"
        )
    lines += ["", "Per relation kind (satisfied / requested, both methods on the same relations):", ""]
    return "\n".join(lines) + "\n" + kinds_table(rows)


def kinds_table(rows: list[dict]) -> str:
    catalog = load_catalog()
    model = OfflineSceneModel(catalog)
    prompts = yaml.safe_load(PROMPTS.read_text(encoding="utf-8"))
    counts: dict[str, dict[str, list[int]]] = {}
    by_key = {(r["theme"], r["prompt"], r["method"]): r for r in rows}
    for theme, texts in prompts.items():
        for number, prompt in enumerate(texts):
            answer, _ = model.ask_json("", [{"role": "user", "content": prompt}])
            kinds = [
                r.kind for r in read_proposal(answer, catalog).relations if r.kind not in ("random_yaw", "anywhere")
            ]
            for method in ("solver", "grid"):
                if (theme, number, method) not in by_key:
                    continue  # a prompt left out of this run
                holds = by_key[(theme, number, method)]["holds"]
                for kind, held in zip(kinds, holds):
                    entry = counts.setdefault(kind, {"solver": [0, 0], "grid": [0, 0]})[method]
                    entry[0] += int(held)
                    entry[1] += 1
    lines = ["| relation | ours | grid baseline |", "|---|---|---|"]
    for kind in sorted(counts):
        ours, grid = counts[kind]["solver"], counts[kind]["grid"]
        lines.append(f"| {kind} | {ours[0]}/{ours[1]} | {grid[0]}/{grid[1]} |")
    return "\n".join(lines) + "\n"


def write_doc(doc: Path, tables: str, begin: str = BEGIN, end: str = END) -> None:
    """Replace what lies between the `begin` and `end` markers of `doc` with `tables`."""
    if not doc.exists():
        print(f"{doc} does not exist: tables not written", file=sys.stderr)
        return
    text = doc.read_text(encoding="utf-8")
    if begin not in text or end not in text:
        print(f"{doc} has no {begin} ... {end} markers: tables not written", file=sys.stderr)
        return
    start, stop = text.index(begin) + len(begin), text.index(end)
    doc.write_text(text[:start] + "\n" + tables + text[stop:], encoding="utf-8")


def picture_grid(rows: list[dict], prompts: dict, out: Path, images: Path) -> None:
    """Previews of a few prompts, ours above the baseline's, labelled; scenes the loader refused are left grey."""
    images.mkdir(parents=True, exist_ok=True)
    label_height = 30
    sheet = Image.new("RGB", (TILE[0] * len(PICTURED), 2 * (TILE[1] + label_height)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    by_key = {(r["theme"], r["prompt"], r["method"]): r for r in rows}
    for column, (theme, number) in enumerate(PICTURED):
        for line, method in enumerate(("solver", "grid")):
            row = by_key[(theme, number, method)]
            x, y = column * TILE[0], line * (TILE[1] + label_height)
            caption = (
                f"{'ours' if method == 'solver' else 'grid'}: {theme.replace('_', ' ')} {number + 1}, "
                f"{row['satisfied']}/{row['requested']} relations"
            )
            draw.text((x + 4, y + 3), caption, fill=(0, 0, 0))
            draw.text(
                (x + 4, y + 15), f"drift {row['max_drift_cm']} cm, collisions {row['collisions']}", fill=(60, 60, 60)
            )
            if row["file"]:
                with tempfile.TemporaryDirectory() as folder:
                    png = render_preview(Path(row["file"]), Path(folder) / "preview.png")
                    tile = Image.open(png).convert("RGB").resize(TILE, Image.LANCZOS)
                sheet.paste(tile, (x, y + label_height))
            else:
                draw.rectangle(
                    [x, y + label_height, x + TILE[0] - 1, y + label_height + TILE[1] - 1], fill=(200, 200, 200)
                )
                draw.text((x + 10, y + label_height + 80), "not a valid scene file (overlaps)", fill=(0, 0, 0))
    path = images / "solver_vs_grid.png"
    sheet.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)
    print(f"picture grid: {path}")


if __name__ == "__main__":
    sys.exit(main())
