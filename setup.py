"""Build hook: ship the start-up file that lets ManiSkill find RoboLab tasks without `import robolab_ms`.

Everything else about the package is declared in pyproject.toml. Installing puts two files at the top of
site-packages: `robolab_ms-autoregister.pth` (one line, read by Python at start-up) and the tiny module it imports,
`_robolab_ms_hook` (copied from robolab_ms/autoregister_hook.py). That module imports nothing heavy; it only waits
for `mani_skill.envs` to be imported and then registers the RoboLab environments.
"""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

TOP_LEVEL_FILES = {
    "robolab_ms/autoregister_hook.py": "_robolab_ms_hook.py",
    "robolab_ms/robolab_ms-autoregister.pth": "robolab_ms-autoregister.pth",
}


class BuildPyWithStartupHook(build_py):
    def run(self) -> None:
        super().run()
        for source, target in TOP_LEVEL_FILES.items():
            self.copy_file(source, str(Path(self.build_lib) / target), preserve_mode=False)

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        extra = [str(Path(self.build_lib) / target) for target in TOP_LEVEL_FILES.values()]
        return super().get_outputs(include_bytecode) + extra


setup(cmdclass={"build_py": BuildPyWithStartupHook})
