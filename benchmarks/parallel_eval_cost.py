"""Episodes per second of `robolab eval` with --workers 1 (in this process), --workers 2 (two worker processes) and
--ray local --workers 2 (two Ray actors on a Ray instance started on this machine), all in one process.

    .venv/bin/python benchmarks/parallel_eval_cost.py [--task BananaInBowl] [--episodes 24] [--max-steps 60]

Each mode runs the same episodes (random policy, state observations) into its own fresh results folder. Printed per
mode: episodes per second over the whole run (worker start-up and Ray's start included) and in steady state (from
the moment every worker has delivered its first episode to the last one), and the speed-ups against --workers 1.
Targets (issue 20): at least 1.7x with 2 workers on a 2-core machine, Ray within 10 % of --workers 2. The numbers
are only meaningful on an otherwise idle machine: other processes take cores from the workers.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")  # Ray on this machine only (127.0.0.1)
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")

from robolab_ms.eval.parallel import PolicySpec, run_parallel  # noqa: E402
from robolab_ms.eval.results import EPISODES_FILE  # noqa: E402
from robolab_ms.eval.runner import EvalConfig, run_evaluation  # noqa: E402
from robolab_ms.policies import PolicyOptions, make_policy  # noqa: E402


class LineClock:
    """Watches a results folder and notes when each episode line appears."""

    def __init__(self, out: Path) -> None:
        self.file, self.times = out / EPISODES_FILE, []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()

    def _watch(self) -> None:
        while not self._stop.is_set():
            count = self._count()
            while len(self.times) < count:
                self.times.append(time.perf_counter())
            time.sleep(0.01)

    def _count(self) -> int:
        try:
            return self.file.read_bytes().count(b"\n")
        except FileNotFoundError:
            return 0

    def stop(self) -> list[float]:
        self._stop.set()
        self._thread.join()
        while len(self.times) < self._count():
            self.times.append(time.perf_counter())
        return self.times


def measure(label: str, workers: int, ray: bool, config: EvalConfig, root: Path) -> tuple[float, float]:
    """(episodes/s over the whole run, episodes/s in steady state) of one mode."""
    out = root / label.replace(" ", "_")
    policy = make_policy("random")
    clock = LineClock(out)
    start = time.perf_counter()
    if workers == 1 and not ray:
        run_evaluation(policy, config, out, show_progress=False)
    else:
        run_parallel(policy, PolicySpec("random", PolicyOptions()), config, out, workers=workers,
                     ray="local" if ray else None, show_progress=False)  # fmt: skip
    end = time.perf_counter()
    times = clock.stop()
    episodes = len(config.tasks) * config.episodes
    assert len(times) == episodes, f"{label}: {len(times)} lines for {episodes} episodes"
    warm = times[workers - 1]  # every worker has delivered one episode (its start-up is behind it)
    steady = (episodes - workers) / (times[-1] - warm)
    whole = episodes / (end - start)
    print(f"{label:>18}: {whole:6.3f} episodes/s whole run ({end - start:6.1f} s), {steady:6.3f} episodes/s steady",
          flush=True)  # fmt: skip
    return whole, steady


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="BananaInBowl")
    parser.add_argument("--episodes", type=int, default=24)
    parser.add_argument("--max-steps", type=int, default=60, help="control steps per episode")
    args = parser.parse_args()

    config = EvalConfig(tasks=(args.task,), episodes=args.episodes, max_steps=args.max_steps)
    print(f"{args.episodes} episodes of {args.task}, {args.max_steps} steps each, random policy; "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}", flush=True)  # fmt: skip
    with tempfile.TemporaryDirectory(prefix="parallel-eval-cost-") as folder:
        root = Path(folder)
        one = measure("--workers 1", 1, False, config, root)
        two = measure("--workers 2", 2, False, config, root)
        ray = measure("--ray local -w 2", 2, True, config, root)
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    for index, kind in enumerate(("whole run", "steady")):
        print(f"speed-up ({kind}): --workers 2 / --workers 1 = {two[index] / one[index]:.2f}x (target >= 1.7); "
              f"Ray / --workers 2 = {ray[index] / two[index]:.2f} (target >= 0.90)")  # fmt: skip


if __name__ == "__main__":
    main()
