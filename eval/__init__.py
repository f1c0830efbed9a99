"""Evaluation: the runner and the results format (importable as robolab_ms.eval)."""
