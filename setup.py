"""Build hook: ship the start-up file that lets ManiSkill find RoboLab tasks without `import robolab_ms`.

Everything else about the package is declared in pyproject.toml. Installing puts two files at the top of
site-packages: `robolab_ms-autoregister.pth` (one line, read by Python at start-up) and the tiny module it imports,
`_robolab_ms_hook` (copied from robolab_ms/autoregister_hook.py). That module imports nothing heavy; it only waits
for `mani_skill.envs` to be imported and then registers the RoboLab environments.

With ROBOLAB_MS_LINK_CHECKOUT=1 in the environment (`make` sets it), the build also writes robolab_ms/checkout.txt,
the path of this source folder: the installed package then reads task specs, scenes and the catalog from the
checkout (robolab_ms.content.content_dir), so edits there take effect without a re-install. Without it (a plain
`pip install .` or a wheel for others) the package reads only its own copies.
"""

import os
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

TOP_LEVEL_FILES = {
    "robolab_ms/autoregister_hook.py": "_robolab_ms_hook.py",
    "robolab_ms/robolab_ms-autoregister.pth": "robolab_ms-autoregister.pth",
}


CHECKOUT_FILE = "robolab_ms/checkout.txt"  # robolab_ms.content.CHECKOUT_FILE, inside the package
CHECKOUT_ENV = "ROBOLAB_MS_LINK_CHECKOUT"  # robolab_ms.content.CHECKOUT_ENV


class BuildPyWithStartupHook(build_py):
    def run(self) -> None:
        super().run()
        for source, target in TOP_LEVEL_FILES.items():
            self.copy_file(source, str(Path(self.build_lib) / target), preserve_mode=False)
        checkout = Path(self.build_lib) / CHECKOUT_FILE
        if os.environ.get(CHECKOUT_ENV) == "1":
            checkout.write_text(str(Path(__file__).resolve().parent) + "\n", encoding="utf-8")
        elif checkout.exists():  # left by an earlier linked build in the same build folder
            checkout.unlink()

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        extra = [str(Path(self.build_lib) / target) for target in TOP_LEVEL_FILES.values()]
        if os.environ.get(CHECKOUT_ENV) == "1":
            extra.append(str(Path(self.build_lib) / CHECKOUT_FILE))
        return super().get_outputs(include_bytecode) + extra


setup(cmdclass={"build_py": BuildPyWithStartupHook})
