"""`pip install .` ships exactly one import namespace, the content folders and the start-up hook."""

import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def wheel_names(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--wheel-dir",
            str(out),
            ".",
        ],
        check=True,
        timeout=300,
    )
    (wheel,) = out.glob("robolab_ms-*.whl")
    return zipfile.ZipFile(wheel).namelist()


def test_one_namespace_plus_the_startup_hook(wheel_names):
    top_level = {name.split("/")[0] for name in wheel_names if ".dist-info" not in name}
    assert top_level == {"robolab_ms", "_robolab_ms_hook.py", "robolab_ms-autoregister.pth"}


def test_content_folders_ship_inside_the_package(wheel_names):
    for expected in (
        "robolab_ms/task_specs/BananaInBowl.yaml",
        "robolab_ms/scene_builders/banana_bowl.yaml",
        "robolab_ms/assets/catalog.yaml",
        "robolab_ms/eval/runner.py",
        "robolab_ms/analysis/tables.py",
    ):
        assert expected in wheel_names, expected


def test_sub_packages_and_their_files_ship(wheel_names):
    """The command's package (with `python -m robolab_ms.cli`) and the leaderboard's page files, read at run time."""
    for expected in (
        "robolab_ms/cli/__init__.py",
        "robolab_ms/cli/__main__.py",
        "robolab_ms/cli/evaluate.py",
        "robolab_ms/analysis/leaderboard/pages.py",
        "robolab_ms/analysis/leaderboard/style.css",
        "robolab_ms/analysis/leaderboard/page.js",
    ):
        assert expected in wheel_names, expected


def test_every_package_folder_is_listed_in_pyproject():
    """pyproject lists packages explicitly: a package folder (one with __init__.py) left out of the list is not
    installed, although a stale build folder or egg-info in a checkout can hide that from a wheel built there."""
    root = Path(__file__).resolve().parent.parent
    listed = set(tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    folders = {
        ".".join(init.parent.relative_to(root).parts)
        for init in (root / "robolab_ms").rglob("__init__.py")
        if "__pycache__" not in init.parts
    }
    missing = sorted(folders - listed)
    assert not missing, f"pyproject.toml [tool.setuptools] packages: add {missing}"


@pytest.mark.slow
def test_regular_install_into_a_fresh_venv_works_like_the_checkout(tmp_path):
    """A fresh venv borrows the dependencies of this one (a .pth line) and gets robolab_ms from `pip install .`."""
    import site
    import venv

    fresh = tmp_path / "venv"
    venv.create(fresh, with_pip=False)
    python = fresh / "bin" / "python"
    purelib = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    (tmp_path / "venv" / purelib.split(str(fresh) + "/")[1] / "deps.pth").write_text(site.getsitepackages()[0] + "\n")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "--python",
            str(python),
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            ".",
        ],
        check=True,
        timeout=300,
    )
    code = (
        "import robolab_ms, mani_skill.envs, gymnasium as gym;"
        "from robolab_ms.tasks.spec import load_task;"
        "print(robolab_ms.__file__); print('RoboLab-BananaInBowl-v1' in gym.registry); print(load_task('BananaInBowl').scene.name)"
    )
    result = subprocess.run([str(python), "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    where, registered, scene = result.stdout.split()
    assert where.startswith(str(fresh)) and registered == "True" and scene == "banana_bowl"
    listing = subprocess.run([str(fresh / "bin" / "robolab"), "list"], capture_output=True, text=True, cwd=tmp_path)
    assert "RoboLab-BananaInBowl-v1" in listing.stdout, listing.stderr
