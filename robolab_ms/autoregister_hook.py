"""Register RoboLab environments as soon as ManiSkill's environments are imported.

Installed at the top of site-packages as `_robolab_ms_hook` and imported by `robolab_ms-autoregister.pth` at every
Python start-up, so it must stay tiny: it imports only `sys` and `os`, and does nothing until some program imports
`mani_skill.envs`. Then it imports `robolab_ms.envs`, which registers one `RoboLab-<Task>-v1` id per task spec.
That is what makes `python -m mani_skill.examples.demo_random_action -e RoboLab-BananaInBowl-v1` work without a
`robolab_ms:` prefix. Set ROBOLAB_MS_AUTOREGISTER=0 to switch it off.
"""

import os
import sys

_TRIGGER = "mani_skill.envs"


class _RegisterAfterManiSkillEnvs:
    """A meta-path finder that never finds anything itself; it wraps the loader of `mani_skill.envs`."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname != _TRIGGER:
            return None
        sys.meta_path.remove(self)
        from importlib.util import find_spec

        spec = find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        original_exec = spec.loader.exec_module

        def exec_then_register(module):
            original_exec(module)
            register()

        spec.loader.exec_module = exec_then_register
        return spec


def register() -> None:
    """Import robolab_ms.envs, which registers every RoboLab task; an error is reported, never raised into ManiSkill.
    Nothing that robolab_ms.envs imports while it registers brings ManiSkill up itself, so this works whichever
    module first imported ManiSkill (see robolab_ms.envs.robolab_env)."""
    try:
        import robolab_ms.envs  # noqa: F401  (registers on import)
    except Exception as error:  # never break ManiSkill because of us
        sys.stderr.write(f"robolab_ms: could not register RoboLab environments: {error}\n")


def install() -> None:
    if os.environ.get("ROBOLAB_MS_AUTOREGISTER", "1") == "0":
        return
    if _TRIGGER in sys.modules:
        register()
    elif not any(type(finder).__name__ == _RegisterAfterManiSkillEnvs.__name__ for finder in sys.meta_path):
        sys.meta_path.insert(0, _RegisterAfterManiSkillEnvs())


install()
