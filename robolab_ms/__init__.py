"""robolab_ms: the RoboLab benchmark as a ManiSkill3 / SAPIEN plugin.

Importing this package is cheap. The `RoboLab-<Task>-v1` environments are registered with ManiSkill and gymnasium
when `robolab_ms.envs` is imported, which happens on its own as soon as a program imports `mani_skill.envs`, and
right away when a program that already uses gymnasium imports `robolab_ms` (as `gym.make("robolab_ms:...")` does).
"""

import sys

from robolab_ms import autoregister_hook as _autoregister

__version__ = "0.1.0"

if "gymnasium" in sys.modules:
    _autoregister.register()
else:
    _autoregister.install()
