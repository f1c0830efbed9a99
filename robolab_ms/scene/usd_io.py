"""Kept for robolab_ms.cli until the CLI is split: USD export and import live in `.usd_export` and `.usd_import`."""

from robolab_ms.scene.usd_export import export_scene
from robolab_ms.scene.usd_import import import_scene

__all__ = ["export_scene", "import_scene"]
