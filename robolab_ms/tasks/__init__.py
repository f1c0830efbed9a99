"""Task engine: task specs, predicates, subtask progress and scores."""
