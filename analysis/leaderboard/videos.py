"""The episode videos a leaderboard links to: copied into the site, linked in the results folders, or left out."""

from __future__ import annotations

import os
import re
import shutil
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from robolab_ms.analysis.runs import RunSet


VIDEO_DIR = "videos"


VIDEO_MODES = ("copy", "link", "none")


@dataclass(frozen=True)
class VideoLink:
    """One episode's video as linked from the site: `href` is relative to the site folder."""

    label: str
    href: str
    success: bool


def collect_videos(runs: RunSet, site: Path, mode: str) -> dict[tuple[str, str], list[VideoLink]]:
    """The video links per (policy, task): files copied into `site/videos/<run>/` (`copy`), relative links to the
    results folders (`link`) or none. Videos whose file is missing or that point outside their results folder are
    skipped with a warning."""
    from robolab_ms.analysis.runs import run_labels

    links: dict[tuple[str, str], list[VideoLink]] = {}
    if mode == "none" or "video" not in runs.episodes:
        return links
    folder_of = dict(zip(run_labels(runs.folders), runs.folders))
    run_dirs = unique_slugs(list(folder_of))
    variants = runs.episodes["instruction_variant"].nunique() > 1
    missing = []
    for row in runs.episodes.sort_values(["policy", "task", "instruction_variant", "seed"]).itertuples(index=False):
        if not isinstance(row.video, str) or not row.video:
            continue
        folder = folder_of[row.run].resolve()
        source = (folder / row.video).resolve()
        if not source.is_relative_to(folder) or not source.is_file():
            missing.append(f"{row.run}/{row.video}")
            continue
        if mode == "copy":
            inside = source.relative_to(folder)  # usually videos/<Task>/<file>.mp4: its videos/ is not repeated
            inside = inside.relative_to(VIDEO_DIR) if inside.parts[0] == VIDEO_DIR and len(inside.parts) > 1 else inside
            target = site / VIDEO_DIR / run_dirs[row.run] / inside
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
            href = target.relative_to(site).as_posix()
        else:
            href = Path(os.path.relpath(source, site.resolve())).as_posix()
        label = f"seed {row.seed}" + (f" {row.instruction_variant}" if variants else "")
        links.setdefault((str(row.policy), str(row.task)), []).append(VideoLink(label, href, bool(row.success)))
    if missing:
        warnings.warn(
            f"{len(missing)} episode video(s) missing or outside their results folder, not linked: "
            + ", ".join(missing[:5])
            + (", ..." if len(missing) > 5 else ""),
            stacklevel=2,
        )
    return links


def _slug(name: str) -> str:
    """A file-name-safe version of a name (letters, digits, `-`, `_`, `.`), never empty or hidden."""
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "item"
    return slug[:80]


def unique_slugs(names: Sequence[str]) -> dict[str, str]:
    """A distinct slug per name, in order (a repeated slug gets -2, -3 ...)."""
    slugs: dict[str, str] = {}
    taken: set[str] = set()
    for name in names:
        base = slug = _slug(name)
        counter = 1
        while slug.lower() in taken:
            counter += 1
            slug = f"{base}-{counter}"
        taken.add(slug.lower())
        slugs[name] = slug
    return slugs
