"""Task specs (one YAML file per task); each becomes the environment id RoboLab-<Task>-v1."""
