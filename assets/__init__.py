"""Object catalog data (catalog.yaml) shipped with robolab_ms."""
