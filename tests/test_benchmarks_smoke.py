"""Every script in benchmarks/ runs at its smallest settings and prints its ratio line.

The scripts are found by glob, so a new one is covered at once. The convention they keep: `--quick` picks the
smallest settings (the script runs end to end; its numbers mean nothing), and the output has a line with the word
"ratio" and a number (the figure the script is for, against a baseline of the same run). Speed is not checked.

Each script runs as its own process in a fresh folder (relative output paths such as results/ land there; a quick
run writes no doc or picture), two at a time: most of their time is start-up, environment builds and first frames,
about 180 CPU seconds for all of them, so the file takes about 2 minutes on an idle 2-core machine.
"""

from __future__ import annotations

import re
import subprocess
import sys
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # every benchmark script as a process, about 2.5 minutes: `make test-slow`

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(path.name for path in BENCHMARKS.glob("*.py"))
RATIO_LINE = re.compile(r"^.*\bratio\b.*\d.*$", re.IGNORECASE | re.MULTILINE)
AT_ONCE = 2
TIMEOUT_S = 900  # per script, on a busy machine


def test_benchmarks_are_found():
    assert len(SCRIPTS) >= 10 and "task_logic_cost.py" in SCRIPTS


@pytest.fixture(scope="module")
def quick_runs(request, tmp_path_factory):
    """Every selected script started with --quick, AT_ONCE at a time: {script: Future of its CompletedProcess}."""
    selected = [
        item.callspec.params["script"]
        for item in request.session.items
        if item.module is request.module and hasattr(item, "callspec")
    ]

    def run(script: str) -> subprocess.CompletedProcess:
        folder = tmp_path_factory.mktemp(Path(script).stem)
        return subprocess.run(
            [sys.executable, str(BENCHMARKS / script), "--quick"],
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )

    with ThreadPoolExecutor(AT_ONCE) as pool:
        futures: dict[str, Future] = {script: pool.submit(run, script) for script in dict.fromkeys(selected)}
        yield futures


@pytest.mark.parametrize("script", SCRIPTS)
def test_benchmark_runs_quick_and_prints_its_ratio(script, quick_runs):
    result = quick_runs[script].result()
    assert result.returncode == 0, f"{script} --quick exited {result.returncode}:\n{result.stderr[-4000:]}"
    assert RATIO_LINE.search(result.stdout), f"{script} --quick printed no ratio line:\n{result.stdout[-3000:]}"
