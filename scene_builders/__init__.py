"""Scene files (one YAML file per scene), built by robolab_ms.scene.RoboLabSceneBuilder."""
