"""Registration: the design card's demo command, the `robolab_ms:` form, and a start-up that stays cheap."""

import os
import subprocess
import sys

import gymnasium as gym
import pytest

DEMO = [sys.executable, "-m", "mani_skill.examples.demo_random_action", "--quiet", "--render-backend", "cpu"]


def run_python(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=600, env={**os.environ, **(env or {})}
    )


@pytest.mark.parametrize("env_id", ["RoboLab-BananaInBowl-v1", "robolab_ms:RoboLab-BananaInBowl-v1"])
def test_demo_random_action_runs_the_task(env_id):
    result = subprocess.run([*DEMO, "-e", env_id], capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]


def test_gym_make_with_module_prefix_in_a_fresh_process():
    code = "import gymnasium as gym; env = gym.make('robolab_ms:RoboLab-BananaInBowl-v1'); print(env.unwrapped.instruction)"
    result = run_python("-c", code)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "Put the banana in the bowl." in result.stdout


def test_startup_hook_imports_nothing_heavy():
    code = "import sys; print(sorted(m for m in ('robolab_ms', 'torch', 'sapien', 'mani_skill', 'yaml') if m in sys.modules))"
    result = run_python("-c", code)
    assert result.returncode == 0 and result.stdout.strip() == "[]", result.stdout + result.stderr
    assert "_robolab_ms_hook" in run_python("-c", "import sys; print(list(sys.modules))").stdout


@pytest.mark.slow
def test_hook_can_be_switched_off():
    code = "import mani_skill.envs, gymnasium as gym; print('RoboLab-BananaInBowl-v1' in gym.registry)"
    assert run_python("-c", code).stdout.strip() == "True"
    assert run_python("-c", code, env={"ROBOLAB_MS_AUTOREGISTER": "0"}).stdout.strip() == "False"


def test_unknown_env_id_suggests_the_close_one():
    with pytest.raises(gym.error.Error, match="BananaInBowl"):
        gym.make("RoboLab-BananaInBowel-v1")


def test_reading_specs_imports_no_simulator():
    code = (
        "import sys, robolab_ms.tasks.spec, robolab_ms.tasks.events;"
        "print(sorted(m for m in ('mani_skill', 'sapien') if m in sys.modules))"
    )
    result = run_python("-c", code)
    assert result.returncode == 0 and result.stdout.strip() == "[]" and result.stderr == "", result.stderr


@pytest.mark.parametrize(
    "module", ["robolab_ms.agents", "robolab_ms.agents.droid", "robolab_ms.scene.builder", "robolab_ms.scene.scene_env"]
)
def test_importing_a_module_that_brings_up_maniskill_still_registers(module):
    # ManiSkill's environments come up half-way through these imports, and the hook registers right then: what it
    # imports must not need the module still being imported
    code = f"import {module}, gymnasium as gym; print('RoboLab-BananaInBowl-v1' in gym.registry)"
    result = run_python("-c", code, env={"PYTHONWARNINGS": "ignore"})
    assert result.returncode == 0 and result.stdout.strip().splitlines()[-1] == "True", result.stdout + result.stderr
    assert "could not register" not in result.stderr
