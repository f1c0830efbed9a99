"""Generated content: scenes (and tasks) proposed by an LLM or an offline generator, checked like hand-written data."""
