"""What robolab_ms's start-up hook costs a Python program that never uses it.

Runs `python -X importtime -c pass` several times and prints, per run and as a median, the import time of
`_robolab_ms_hook` against the whole start-up of the interpreter measured in the same run.

    .venv/bin/python benchmarks/startup_cost.py [--runs 20]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys


def one_run() -> tuple[int, int]:
    """(hook microseconds, total start-up import microseconds) of one fresh interpreter."""
    stderr = subprocess.run([sys.executable, "-X", "importtime", "-c", "pass"], capture_output=True, text=True).stderr
    hook, total = 0, 0
    for line in stderr.splitlines():
        if not line.startswith("import time:") or "|" not in line or "self [us]" in line:
            continue
        _, cumulative, name = line.split(":", 1)[1].split("|")
        if name.startswith(" ") and not name.startswith("  "):
            total += int(cumulative)  # top-level imports only (one space, no nesting), so nothing counts twice
        if name.strip() == "_robolab_ms_hook":
            hook = int(cumulative)
    return hook, total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.runs = 2
    runs = [one_run() for _ in range(args.runs)]
    if not any(hook for hook, _ in runs):
        sys.exit("_robolab_ms_hook was not imported: is robolab_ms installed in this interpreter?")
    hooks = [hook for hook, _ in runs]
    ratios = [hook / total for hook, total in runs]
    print(f"runs: {args.runs}")
    print(
        f"hook import: median {statistics.median(hooks) / 1000:.3f} ms (min {min(hooks) / 1000:.3f}, max {max(hooks) / 1000:.3f})"
    )
    print(f"ratio hook / whole start-up imports: median {100 * statistics.median(ratios):.1f} %")


if __name__ == "__main__":
    main()
