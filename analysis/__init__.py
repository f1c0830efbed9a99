"""Analysis: tables and statistics derived from results (importable as robolab_ms.analysis)."""
