"""Task generation, offline backend: how many generated tasks pass the judge and `robolab validate`, and how good
the rules judge is.

    PYTHONPATH=. python benchmarks/task_generation.py [--seeds 3] [--rounds 3] [--out results/task_generation]
        [--doc docs/generation.md] [--methods solver grid]

1. The rules judge on the 120 hand-written tasks: each task's own default instruction with its own condition (the
   judge should accept), and each instruction with the condition of every other task on the same scene whose
   condition differs (it should reject).
2. The offline backend on RoboLab's 120 default instructions, against the hand-written conditions: the same
   predicate, objects, logical (and k) and container or reference.
3. Generated tasks on generated scenes: for each of the 20 scene prompts of benchmarks/fixtures/
   generation_prompts.yaml (RoboLab's 10 themes x 2), the scene is generated (per method: ours and RoboLab's grid
   baseline, as in generation_compare.py), then `robolab generate task` runs on it with the instruction written
   for that prompt (benchmarks/fixtures/generation_task_instructions.yaml), offline backend and rules judge,
   validating every round with --seeds seeds. Per method: tasks accepted (judge and validate passed within the
   rounds), passed in the first round, judged aligned, rounds and time per task.

Writes OUT/tasks.csv and the tables between the markers of the doc's task section.
"""

from __future__ import annotations

import argparse
import csv
import re
import statistics
import sys
import time
from pathlib import Path

import yaml
from generation_compare import write_doc  # the marked-section writer of the scene benchmark, beside this script

from robolab_ms.catalog import load_catalog
from robolab_ms.generation.judge import ALIGNED, MISALIGNED, RulesJudge
from robolab_ms.generation.llm import GenerationError
from robolab_ms.generation.offline import OfflineSceneModel
from robolab_ms.generation.offline_task import OfflineTaskModel
from robolab_ms.generation.proposal import read_proposal
from robolab_ms.generation.scene import generate_scene
from robolab_ms.generation.task import generate_task
from robolab_ms.scene import read_scene
from robolab_ms.tasks.spec import load_all_tasks

FIXTURES = Path(__file__).parent / "fixtures"
PROMPTS, INSTRUCTIONS = FIXTURES / "generation_prompts.yaml", FIXTURES / "generation_task_instructions.yaml"
BEGIN, END = "<!-- task_generation:begin -->", "<!-- task_generation:end -->"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="results/task_generation")
    parser.add_argument("--doc", default="docs/generation.md")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--methods", nargs="+", default=["solver", "grid"], choices=("solver", "grid"))
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: the first prompt, one seed, one "
        "round, no doc written; only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args(argv)
    if args.quick:
        args.seeds, args.rounds = 1, 1
    started = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    catalog = load_catalog()
    judge_table = judge_on_handwritten(catalog)
    print(judge_table, flush=True)
    first = 1 if args.quick else None
    rows = generated_tasks(catalog, out, args.methods, args.seeds, args.rounds, prompts_per_theme=first, themes=first)
    with (out / "tasks.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    minutes = (time.perf_counter() - started) / 60
    command = (
        f"PYTHONPATH=. python benchmarks/task_generation.py --seeds {args.seeds} --rounds {args.rounds} "
        f"--methods {' '.join(args.methods)}"
    )
    tables = (
        f"Measured with `{command}` (validation seeds 0..{args.seeds - 1} in every round; {minutes:.0f} min "
        "wall time for the whole run on 2 CPU cores shared with other work, no GPU).\n\n"
        + generated_tables(rows)
        + "\n"
        + judge_table
    )
    print(tables)
    print(ratio_line(rows))
    if not args.quick:
        write_doc(Path(args.doc), tables, BEGIN, END)
    return 0


def ratio_line(rows: list[dict]) -> str:
    """Ours against the grid baseline: the shares of generated tasks accepted (judge and validate passed)."""
    shares = {}
    for method in dict.fromkeys(row["method"] for row in rows):
        mine = [row for row in rows if row["method"] == method]
        shares[method] = sum(row["accepted"] for row in mine) / len(mine)
    if set(shares) != {"solver", "grid"}:
        return (
            "ratio ours / grid baseline, tasks accepted: needs both methods ("
            + ", ".join(f"{method} {share:.2f}" for method, share in shares.items())
            + ")"
        )
    ratio = f"{shares['solver'] / shares['grid']:.2f}" if shares["grid"] else "inf (the baseline had none accepted)"
    return f"ratio ours / grid baseline, tasks accepted: {shares['solver']:.2f} / {shares['grid']:.2f} = {ratio}"


# ------------------------------------------------------------------------------------------------ 1 and 2
def judge_on_handwritten(catalog) -> str:
    """The rules judge on the shipped tasks and on mismatched pairs; the offline backend against them."""
    judge = RulesJudge(catalog)
    specs = load_all_tasks()
    own = [judge.judge(spec.instructions["default"], spec) for spec in specs]

    def key(spec):
        c = spec.success[0]
        return (
            c.predicate,
            tuple(sorted(c.objects)),
            tuple(sorted(c.references.items())),
            c.logical,
            c.k,
            repr(c.params.get("groups")),
        )

    pairs = [(a, b) for a in specs for b in specs if a is not b and a.scene.file == b.scene.file and key(a) != key(b)]
    crossed = [judge.judge(a.instructions["default"], b) for a, b in pairs]
    agree, failed = 0, 0
    for spec in specs:
        try:
            made = OfflineTaskModel(catalog, spec.scene).answer(spec.instructions["default"])["success"][0]
        except GenerationError:
            failed += 1
            continue
        gold = spec.success[0]
        objects = made.get("objects") or [o for members in made.get("groups", {}).values() for o in members]
        places = {k: made[k] for k in ("container", "reference") if k in made}
        agree += (
            made["predicate"] == gold.predicate
            and sorted(objects) == sorted(gold.objects)
            and made.get("logical", "all") == gold.logical
            and made.get("k", 1) == gold.k
            and all(gold.references.get(k) == v for k, v in places.items())
        )

    def count(verdicts, verdict):
        return sum(v.verdict == verdict for v in verdicts)

    n, m = len(own), len(crossed)
    lines = [
        "| check on the 120 hand-written tasks | result |",
        "|---|---|",
        f"| rules judge accepts a task's own instruction and condition | {count(own, ALIGNED)}/{n} "
        f"({100 * count(own, ALIGNED) / n:.0f} %); unsure {n - count(own, ALIGNED) - count(own, MISALIGNED)} |",
        f"| rules judge rejects an instruction with another task's condition on the same scene | "
        f"{count(crossed, MISALIGNED)}/{m} ({100 * count(crossed, MISALIGNED) / m:.0f} %) |",
        f"| offline backend writes the hand-written condition from RoboLab's instruction | {agree}/{n} "
        f"({100 * agree / n:.0f} %); no condition for {failed} |",
    ]
    rejected = [(spec.name, verdict.problems[0]) for spec, verdict in zip(specs, own) if verdict.verdict != ALIGNED]
    lines += ["", "The hand-written tasks the rules judge does not accept, with its first reason:", ""]
    lines += [f"- {name}: {problem}" for name, problem in rejected]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------------------ 3
def generated_tasks(
    catalog,
    out: Path,
    methods: list[str],
    seeds: int,
    rounds: int,
    prompts_per_theme: int | None = None,
    themes: int | None = None,
) -> list[dict]:
    """A generated task per prompt (the first `prompts_per_theme` of the first `themes` themes; default all) and
    method."""
    prompts = yaml.safe_load(PROMPTS.read_text(encoding="utf-8"))
    prompts = {theme: texts[:prompts_per_theme] for theme, texts in list(prompts.items())[:themes]}
    instructions = yaml.safe_load(INSTRUCTIONS.read_text(encoding="utf-8"))
    scene_model = OfflineSceneModel(catalog)
    judge = RulesJudge(catalog)
    rows = []
    for theme, texts in prompts.items():
        for number, prompt in enumerate(texts):
            answer, _ = scene_model.ask_json("", [{"role": "user", "content": prompt}])
            requested = [
                r for r in read_proposal(answer, catalog).relations if r.kind not in ("random_yaw", "anywhere")
            ]
            instruction = instructions[theme][number]
            for method in methods:
                folder = out / method
                scene_file = folder / "scene_builders" / f"{theme}_{number}.yaml"
                scene = generate_scene(
                    prompt, scene_file, scene_model, method=method, render=False, catalog=catalog, requested=requested
                )
                name = "Gen" + "".join(part.title() for part in theme.split("_")) + f"{number}{method.title()}"
                row = {
                    "theme": theme,
                    "prompt": number,
                    "method": method,
                    "instruction": instruction,
                    "scene_written": int(scene.scene_file is not None),
                    "accepted": 0,
                    "rounds": 0,
                    "first_round": 0,
                    "judge_first": "",
                    "judge_last": "",
                    "predicate": "",
                    "stopped_at": "",
                    "oracle": "",
                    "random": "",
                    "at_reset": "",
                    "seconds": 0.0,
                    "validate_seconds": 0.0,
                    "problems": "",
                }
                if scene.scene_file is None:
                    row["stopped_at"], row["problems"] = "scene", "; ".join(scene.problems)
                    rows.append(row)
                    print(f"{theme}/{number} {method}: no scene", flush=True)
                    continue
                spec = read_scene(scene.scene_file, catalog)
                result = generate_task(
                    spec,
                    instruction,
                    folder / "task_specs" / f"{name}.yaml",
                    OfflineTaskModel(catalog, spec),
                    judge,
                    rounds=rounds,
                    seeds=seeds,
                    catalog=catalog,
                )
                validation = result.validation
                row.update(
                    {
                        "accepted": int(result.accepted),
                        "rounds": result.rounds,
                        "first_round": int(result.accepted and result.rounds == 1),
                        "judge_first": result.first_judgement.verdict if result.first_judgement else "",
                        "judge_last": result.judgement.verdict if result.judgement else "",
                        "predicate": (result.condition or {}).get("predicate", ""),
                        "stopped_at": result.stopped_at,
                        "oracle": validation.oracle_success if validation else "",
                        "random": validation.random_success if validation else "",
                        "at_reset": validation.success_at_reset if validation else "",
                        "seconds": round(result.seconds, 1),
                        "validate_seconds": round(result.validate_seconds, 1),
                        "problems": " | ".join(result.problems),
                    }
                )
                rows.append(row)
                print(
                    f"{theme}/{number} {method}: {instruction} -> {row['predicate']}, accepted {row['accepted']} "
                    f"in {row['rounds']} round(s), judge {row['judge_first']}/{row['judge_last']}, oracle "
                    f"{row['oracle']}, random {row['random']}, {row['seconds']} s {row['problems'][:200]}",
                    flush=True,
                )
    return rows


def generated_tables(rows: list[dict]) -> str:
    lines = [
        "| scenes of | tasks accepted (judge + validate) | passed in the first round | judge aligned (first "
        "answer) | rounds (mean) | time per task (s, median; validating) |",
        "|---|---|---|---|---|---|",
    ]
    for method in dict.fromkeys(row["method"] for row in rows):
        mine = [row for row in rows if row["method"] == method]
        judged = [row for row in mine if row["judge_first"]]
        accepted = sum(row["accepted"] for row in mine)
        first = sum(row["first_round"] for row in mine)
        aligned = sum(row["judge_first"] == ALIGNED for row in judged)
        tried = [row for row in mine if row["rounds"]]
        label = "ours (`--method solver`)" if method == "solver" else "RoboLab's grid baseline (`--method grid`)"
        lines.append(
            f"| {label} | {accepted}/{len(mine)} ({100 * accepted / len(mine):.0f} %) | {first}/{len(mine)} | "
            f"{aligned}/{len(judged)} | {statistics.mean(r['rounds'] for r in tried):.1f} | "
            f"{statistics.median(r['seconds'] for r in tried):.0f} "
            f"({statistics.median(r['validate_seconds'] for r in tried):.0f}) |"
        )
    lines += [
        "",
        "Per task (ours / grid baseline: accepted in N rounds, or the check the last round stopped at):",
        "",
        "| theme | instruction | condition | ours | grid baseline |",
        "|---|---|---|---|---|",
    ]
    by_key = {(r["theme"], r["prompt"], r["method"]): r for r in rows}
    for theme, number in dict.fromkeys((r["theme"], r["prompt"]) for r in rows):
        cells = []
        for method in ("solver", "grid"):
            row = by_key.get((theme, number, method))
            if row is None:
                cells.append("-")
            elif row["accepted"]:
                cells.append(f"yes ({row['rounds']})")
            else:
                cells.append(f"no: {row['stopped_at']}" + (f" ({_short(row['problems'])})" if row["problems"] else ""))
        predicate = next(
            (
                by_key[(theme, number, m)]["predicate"]
                for m in ("solver", "grid")
                if (theme, number, m) in by_key and by_key[(theme, number, m)]["predicate"]
            ),
            "",
        )
        instruction = next(r["instruction"] for r in rows if r["theme"] == theme and r["prompt"] == number)
        lines.append(
            f"| {theme.replace('_', ' ')} {number + 1} | {instruction} | {predicate} | {cells[0]} | {cells[1]} |"
        )
    return "\n".join(lines) + "\n"


def _short(problems: str) -> str:
    first = problems.split(" | ")[0]
    first = re.sub(r"^robolab validate \(\d+ seed\(s\)\): ", "", first)
    return first[:110].replace("|", "/")


if __name__ == "__main__":
    sys.exit(main())
