"""`robolab leaderboard`: the site in a real headless Chromium (ranking, escaping, sorting by clicking, readable
without scripts, screenshot into docs), the sim-to-real comparison on known data, and the real-world CSV checks."""

from __future__ import annotations

import json
import math
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from chromium import HeadlessChromium, find_chromium
from scipy.stats import pearsonr

from robolab_ms.analysis import leaderboard
from robolab_ms.analysis.runs import load_runs
from robolab_ms.analysis.synthetic import write_synthetic_run
from robolab_ms.cli import main as robolab
from robolab_ms.errors import RoboLabError

REPO = Path(__file__).resolve().parents[1]
SCREENSHOT = REPO / "docs" / "images" / "analysis" / "leaderboard.png"
TASKS = ["BananaInBowl", "RubiksCubeLeftOfBowl", "BlockStackingSpecifiedOrder", "MarkerInMug", "BananasInCrate"]
HOSTILE = "<script>alert(1)</script>"
AMPERSAND = 'a&b"'
# (policy, success probability, episodes per task): the rank order is the list order; the episode counts sort
# differently as numbers (15 < 20 < 150) and as text ("15" < "150" < "20")
POLICIES = [("good", 0.9, 3), (HOSTILE, 0.55, 4), (AMPERSAND, 0.15, 30)]


def _write_video(path: Path) -> None:
    """A real (tiny) mp4 file."""
    import imageio.v2 as imageio

    path.parent.mkdir(parents=True, exist_ok=True)
    frames = [np.full((64, 64, 3), 40 * i, dtype=np.uint8) for i in range(4)]
    imageio.mimwrite(path, frames, fps=4, macro_block_size=16)


def _three_policies(root: Path) -> list[Path]:
    """Synthetic runs of the three policies; the first has a recorded video for BananaInBowl seed 0."""
    folders = []
    for index, (policy, success, episodes) in enumerate(POLICIES):
        folder = write_synthetic_run(root / f"run{index}", policy, TASKS, episodes, success, seed=index)
        folders.append(folder)
    lines = [json.loads(line) for line in (folders[0] / "episodes.jsonl").read_text().splitlines()]
    for line in lines:
        if line["task"] == "BananaInBowl" and line["seed"] == 0:
            line["video"] = "videos/BananaInBowl/seed0.mp4"
    (folders[0] / "episodes.jsonl").write_text("".join(json.dumps(line) + "\n" for line in lines))
    _write_video(folders[0] / "videos" / "BananaInBowl" / "seed0.mp4")
    return folders


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("leaderboard")
    folders = _three_policies(root)
    board = leaderboard.write_site(load_runs(folders), root / "site")
    assert list(board.ranking["policy"]) == [policy for policy, _, _ in POLICIES]
    return root / "site"


NAMES = "Array.from(document.querySelectorAll('#ranking tbody td.name')).map(cell => cell.textContent)"


@pytest.fixture(scope="module")
def chromium() -> str:
    executable = find_chromium()
    if executable is None:
        pytest.skip("no Chromium on this machine: install Debian's `chromium` package (.ci/run does so in CI)")
    return executable


@pytest.mark.slow
def test_site_in_headless_chromium(site, chromium):
    with HeadlessChromium(chromium) as browser:
        # any alert() the page might run is recorded instead of shown
        browser.call(
            "Page.addScriptToEvaluateOnNewDocument",
            source="window.__alerts = []; window.alert = m => window.__alerts.push(String(m));",
        )
        browser.open((site / "index.html").as_uri())
        assert browser.evaluate(NAMES) == [policy for policy, _, _ in POLICIES]
        assert browser.evaluate("document.querySelectorAll('#ranking tbody td:first-child')[2].textContent") == "3"
        # the hostile names are text: no element or script came out of them, nothing ran
        assert browser.evaluate("document.querySelectorAll('script').length") == 1
        assert browser.evaluate("window.__alerts") == []
        assert browser.evaluate("document.body.innerText.includes('<script>alert(1)</script>')")
        assert browser.evaluate(
            "Array.from(document.querySelectorAll('#tasks thead th')).map(h => h.textContent).slice(3)"
        ) == [policy for policy, _, _ in POLICIES]
        assert browser.evaluate("document.title") == "RoboLab leaderboard"

        # clicking the Episodes header sorts by number (15, 20, 150), a second click reverses
        episodes_header = "#ranking thead th:nth-child(12)"
        assert browser.evaluate(f"document.querySelector('{episodes_header}').textContent") == "Episodes"
        browser.click(episodes_header)
        assert browser.evaluate(NAMES) == ["good", HOSTILE, AMPERSAND]
        assert browser.evaluate(f"document.querySelector('{episodes_header}').getAttribute('aria-sort')") == (
            "ascending"
        )
        browser.click(episodes_header)
        assert browser.evaluate(NAMES) == [AMPERSAND, HOSTILE, "good"]
        browser.click("#ranking thead th:nth-child(2)")  # Policy: as text
        assert browser.evaluate(NAMES) == [HOSTILE, AMPERSAND, "good"]
        browser.click("#ranking thead th:nth-child(1)")  # Rank: back to the ranking
        assert browser.evaluate(NAMES) == [policy for policy, _, _ in POLICIES]
        browser.screenshot(SCREENSHOT)

        # a task page: its table, the copied video, the way back
        browser.open((site / "tasks" / "BananaInBowl.html").as_uri())
        assert browser.evaluate(
            "Array.from(document.querySelectorAll('#policies td.name')).map(c => c.textContent)"
        ) == [policy for policy, _, _ in POLICIES]
        href = browser.evaluate("document.querySelector('.videos a').getAttribute('href')")
        assert href == "../videos/run0/BananaInBowl/seed0.mp4"
        assert (site / "tasks" / href).resolve().read_bytes()[4:8] == b"ftyp"  # an mp4 inside the site folder
        assert browser.evaluate("document.querySelector('a[href=\"../index.html\"]') !== null")

        # with scripting off the page still shows the ranking, in rank order, unsorted by any script
        browser.call("Emulation.setScriptExecutionDisabled", value=True)
        browser.open((site / "index.html").as_uri())
        assert browser.evaluate(NAMES) == [policy for policy, _, _ in POLICIES]
        assert browser.evaluate("document.querySelector('#ranking th').hasAttribute('tabindex')") is False
    assert SCREENSHOT.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


class _Cells(HTMLParser):
    """Texts of the cells of one table, and every tag seen, as a browser's parser reads the file."""

    def __init__(self, table_id: str) -> None:
        super().__init__()
        self.table_id, self.inside, self.cells, self.tags, self.cell = table_id, False, [], [], None

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag == "table":
            self.inside = dict(attrs).get("id") == self.table_id
        if self.inside and tag in ("td", "th"):
            self.cell = ""

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self.cell is not None:
            self.cells.append(self.cell)
            self.cell = None
        if tag == "table":
            self.inside = False

    def handle_data(self, data):
        if self.cell is not None:
            self.cell += data


def test_hostile_task_and_policy_names_stay_text_in_html_and_markdown(tmp_path):
    task = 'Odd<b>Task</b>&"x'
    write_synthetic_run(tmp_path / "r", HOSTILE, [task], 3, 0.5)
    with pytest.warns(UserWarning, match="no task file"):
        runs = load_runs([tmp_path / "r"])
    board = leaderboard.write_site(runs, tmp_path / "site", title="Lab <i>x</i>")
    page = tmp_path / "site" / board.task_pages[task]
    assert page.parent.name == "tasks" and page.name == "Odd_b_Task_b_x.html" and page.exists()
    for file, table in ((tmp_path / "site" / "index.html", "tasks"), (page, "policies")):
        parser = _Cells(table)
        parser.feed(file.read_text())
        assert parser.tags.count("script") == 1 and "b" not in parser.tags and "i" not in parser.tags
        assert HOSTILE in parser.cells and (task in parser.cells or table == "policies")
    markdown = (tmp_path / "site" / "leaderboard.md").read_text()
    assert "<script>" not in markdown and "<b>" not in markdown
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in markdown and 'Odd&lt;b&gt;Task&lt;/b&gt;&amp;"x' in markdown


def test_site_refuses_a_folder_that_is_not_a_leaderboard(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep me")
    write_synthetic_run(tmp_path / "r", "p", TASKS[:1], 2, 0.5)
    with pytest.raises(RoboLabError, match="not a leaderboard site"):
        leaderboard.write_site(load_runs([tmp_path / "r"]), tmp_path / "mine")
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep me"
    # an earlier site is rewritten: its old task pages go
    leaderboard.write_site(load_runs([tmp_path / "r"]), tmp_path / "again")
    (tmp_path / "again" / "tasks" / "Old.html").write_text("old")
    leaderboard.write_site(load_runs([tmp_path / "r"]), tmp_path / "again")
    assert sorted(p.name for p in (tmp_path / "again" / "tasks").iterdir()) == ["BananaInBowl.html"]


def test_ranking_ties_share_a_rank_and_fall_back_to_score():
    import pandas as pd

    episodes = pd.DataFrame(
        {
            "policy": ["b", "b", "a", "a", "c", "c", "d", "d"],
            "task": ["T"] * 8,
            "success": [True, False, True, False, True, False, True, True],
            "score": [1.0, 0.5, 1.0, 0.5, 1.0, 0.0, 1.0, 1.0],
            "progress": [1.0, 0.5, 1.0, 0.5, 1.0, 0.0, 1.0, 1.0],
        }
    )
    ranking = leaderboard.rank_policies(episodes)
    assert list(ranking["policy"]) == ["d", "a", "b", "c"] and list(ranking["rank"]) == [1, 2, 2, 4]
    assert math.isnan(ranking["score_fail"][0]) and list(ranking["score_fail"][1:]) == [0.5, 0.5, 0.0]


def test_correlation_on_known_data():
    # Fisher z interval of r = 0.8 over 10 pairs: tanh(atanh(0.8) -+ 1.96 / sqrt(7)) = (0.3433, 0.9507)
    low, high = leaderboard.fisher_interval(0.8, 10)
    assert low == pytest.approx(0.3433, abs=1e-4) and high == pytest.approx(0.9507, abs=1e-4)
    # Spearman's interval is wider by sqrt(1.06)
    s_low, s_high = leaderboard.fisher_interval(0.8, 10, "Spearman")
    assert s_low < low and s_high > high
    assert leaderboard.fisher_interval(0.8, 3) is None and leaderboard.fisher_interval(1.0, 10) is None

    sim = [0.10, 0.25, 0.40, 0.55, 0.70, 0.85]
    linear = [0.05 + 0.5 * s for s in sim]
    pearson = leaderboard.correlate(sim, linear, "Pearson")
    assert pearson.r == pytest.approx(1.0) and pearson.fisher is None and "not defined" in pearson.note
    cubic = [s**3 for s in sim]  # monotone, not linear: rho = 1, r < 1
    assert leaderboard.correlate(sim, cubic, "Spearman").r == pytest.approx(1.0)
    reversed_order = leaderboard.correlate(sim, cubic[::-1], "Spearman")
    assert reversed_order.r == pytest.approx(-1.0)
    noisy = [0.2, 0.1, 0.45, 0.4, 0.8, 0.7]
    result = leaderboard.correlate(sim, noisy, "Pearson")
    reference = pearsonr(sim, noisy)
    assert result.r == pytest.approx(reference.statistic) and result.p_value == pytest.approx(reference.pvalue)
    assert result.fisher[0] < result.r < result.fisher[1] and result.bootstrap[0] < result.r <= result.bootstrap[1]
    assert result.fisher == pytest.approx(tuple(reference.confidence_interval(0.95)))

    two = leaderboard.correlate([0.1, 0.9], [0.2, 0.8], "Pearson")
    assert two.r is None and "at least 3" in two.note
    three = leaderboard.correlate([0.1, 0.5, 0.9], [0.2, 0.3, 0.8], "Pearson")
    assert three.r is not None and three.fisher is None and "at least 4" in three.note
    flat = leaderboard.correlate([0.1, 0.5, 0.9], [0.3, 0.3, 0.3], "Spearman")
    assert flat.r is None and "real success rate is the same" in flat.note


@pytest.mark.slow
def test_sim_to_real_section_plot_and_cli(tmp_path, capsys):
    rates = {"alpha": 0.85, "beta": 0.6, "gamma": 0.4, "delta": 0.15}
    folders = [
        write_synthetic_run(tmp_path / name, name, TASKS, 6, rate, seed=i)
        for i, (name, rate) in enumerate(rates.items())
    ]
    real = tmp_path / "real.csv"
    real.write_text(
        "policy,success,episodes,notes\nalpha,70%,20,lab A\nbeta,0.55,20,\ngamma,0.2,,\n"
        "delta,0.1,10,\nepsilon,0.5,10,not simulated\n"
    )
    out = tmp_path / "site"
    assert robolab(["leaderboard", *map(str, folders), "--out", str(out), "--real-world", str(real)]) == 0
    printed = capsys.readouterr().out
    assert "sim to real, Pearson over 4 policies: +" in printed and "sim to real, Spearman over 4 policies" in printed
    assert printed.index("| alpha") < printed.index("| beta") < printed.index("| gamma") < printed.index("| delta")
    assert (out / "sim_to_real.png").read_bytes()[:4] == b"\x89PNG" and (out / "sim_to_real.svg").exists()
    index = (out / "index.html").read_text()
    assert 'src="sim_to_real.png"' in index and "epsilon" in index and "Only 4 policies" in index
    markdown = (out / "leaderboard.md").read_text()
    assert "![real against simulated success](sim_to_real.png)" in markdown and "Spearman rho" in markdown

    few = tmp_path / "few.csv"
    few.write_text("policy,success\nalpha,0.7\nbeta,0.5\n")
    assert robolab(["leaderboard", *map(str, folders), "--out", str(out), "--real-world", str(few)]) == 0
    assert "needs at least 3" in capsys.readouterr().out
    assert "needs at least 3" in (out / "leaderboard.md").read_text()


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (None, "no such file"),
        ("", "the file is empty"),
        ("name,success\nalpha,0.5\n", "no column 'policy'"),
        ("policy,sucess\nalpha,0.5\n", "no column 'success'.*Did you mean 'sucess'"),
        ("policy,success\n", "a header but no rows"),
        ("policy,success\nalpha,0.5\nbeta\n", r"row 2 \(line 3\): 1 fields where the header has 2"),
        ("policy,success\nalpha,high\n", r"row 1 \(line 2\), column 'success': 'high' is not a number"),
        ("policy,success\nalpha,45\n", "column 'success': 45 is outside 0..1.*percentage with its sign"),
        ("policy,success\nalpha,120%\n", "column 'success': 120% is outside 0..100"),
        ("policy,success\nalpha,nan\n", "not a finite number"),
        ("policy,success\n,0.5\n", "column 'policy': empty"),
        (
            "policy,success\nalpha,0.5\n\nalpha,0.6\n",
            r"row 2 \(line 4\), column 'policy': 'alpha' already given on line 2",
        ),
        ("policy,success,episodes\nalpha,0.5,ten\n", "column 'episodes': 'ten' is not a whole number"),
        ("policy,success,policy\nalpha,0.5,b\n", "column 'policy' appears twice"),
    ],
)
def test_real_world_csv_errors_name_file_row_and_column(tmp_path, content, expected):
    path = tmp_path / "real_world.csv"
    if content is not None:
        path.write_text(content)
    with pytest.raises(RoboLabError, match=expected) as error:
        leaderboard.read_real_world(path)
    assert str(error.value).startswith(str(path))


def test_real_world_csv_reads_fractions_percentages_and_a_byte_order_mark(tmp_path):
    path = tmp_path / "real.csv"
    path.write_bytes("\ufeffPolicy , Success\n pi0 , 45% \npi0.5,0.625\n".encode())
    rows = leaderboard.read_real_world(path)
    expected = [("pi0", 0.45, None, 2), ("pi0.5", 0.625, None, 3)]
    assert [(r.policy, r.success, r.episodes, r.line) for r in rows] == expected


def test_cli_reports_a_bad_csv_in_one_line(tmp_path, capsys):
    write_synthetic_run(tmp_path / "r", "p", TASKS[:1], 2, 0.5)
    bad = tmp_path / "bad.csv"
    bad.write_text("policy,success\np,2\n")
    assert robolab(["leaderboard", str(tmp_path / "r"), "--out", str(tmp_path / "s"), "--real-world", str(bad)]) == 2
    error = capsys.readouterr().err
    assert error.startswith("robolab: error: ") and "bad.csv: row 1 (line 2), column 'success'" in error
    assert not (tmp_path / "s").exists()
