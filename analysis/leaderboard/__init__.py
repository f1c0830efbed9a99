"""A static leaderboard site over results folders, its Markdown twin, and RoboLab's sim-to-real comparison.

`robolab leaderboard RUN_DIR [RUN_DIR ...] --out SITE` writes:

- `SITE/index.html`: policies ranked by overall success (95 % Beta interval), success per competency axis and per
  difficulty, Score, Score(fail), episodes and tasks; a policies x tasks table linking to the task pages; the
  sim-to-real section with `--real-world`;
- `SITE/tasks/<Task>.html`: one page per task: its scene, difficulty, axes, attributes and instructions, and per
  policy success with its interval, score, time to success, SPARC, path length, speed and the episode videos;
- `SITE/leaderboard.md`: the same tables in Markdown (video links and plot relative to SITE);
- `SITE/videos/<run>/...`: copies of the recorded episode videos (`--videos copy`, the default);
- `SITE/sim_to_real.png`, `.svg`: with `--real-world`, real against simulated success, one point per policy.

Ranking rule: policies are ordered by overall success rate (successes / episodes over every episode of the
policy), ties by mean score, then by name; policies equal in both rate and score share a rank.

The pages are plain HTML with inline CSS, readable with scripting off and from any folder (no server, no file from
elsewhere). A short inline script makes every table sortable: click a header to sort by it (numbers as numbers,
missing values last), click again to reverse. The style sheet and the script are package files beside the modules
(`style.css`, `page.js`). Every name and text that comes from results or the real-world file
is HTML-escaped (and Markdown-escaped in the Markdown copy).

Videos: by default each episode's mp4 is copied into the site, so the folder works when moved or served anywhere;
`--videos link` links to the results folders instead (relative links: the site then works only next to them) and
`--videos none` leaves the links out. The site folder is emptied of an earlier leaderboard's pages before
writing; a non-empty folder that is not a leaderboard site is refused.

The modules, one concept each: `.ranking` (the ranking rule, success per group and task), `.sim_to_real` (the
real-world file and the correlation), `.videos` (episode videos), `.board` (what the pages show, the site's files),
`.pages` (HTML), `.markdown` (Markdown) and `.site` (writing the folder; the command's options and run). The names
other modules use are imported here.
"""

from robolab_ms.analysis.leaderboard.board import INDEX_HTML, MARKDOWN, TASK_DIR, Leaderboard, build_leaderboard
from robolab_ms.analysis.leaderboard.markdown import leaderboard_markdown
from robolab_ms.analysis.leaderboard.pages import index_html, task_html
from robolab_ms.analysis.leaderboard.ranking import Rate, group_rates, rank_policies, task_policy_table
from robolab_ms.analysis.leaderboard.sim_to_real import (
    PLOT_STEM,
    Correlation,
    RealWorldResult,
    SimToReal,
    compare_sim_to_real,
    correlate,
    fisher_interval,
    plot_sim_to_real,
    read_real_world,
)
from robolab_ms.analysis.leaderboard.site import SITE_MARKER, add_arguments, run, write_site
from robolab_ms.analysis.leaderboard.videos import VIDEO_DIR, VIDEO_MODES, VideoLink, collect_videos

__all__ = [
    "INDEX_HTML",
    "MARKDOWN",
    "PLOT_STEM",
    "SITE_MARKER",
    "TASK_DIR",
    "VIDEO_DIR",
    "VIDEO_MODES",
    "Correlation",
    "Leaderboard",
    "Rate",
    "RealWorldResult",
    "SimToReal",
    "VideoLink",
    "add_arguments",
    "build_leaderboard",
    "collect_videos",
    "compare_sim_to_real",
    "correlate",
    "fisher_interval",
    "group_rates",
    "index_html",
    "leaderboard_markdown",
    "plot_sim_to_real",
    "rank_policies",
    "read_real_world",
    "run",
    "task_html",
    "task_policy_table",
    "write_site",
]
