"""The bench around plant and controller: bus, nodes, launcher, recorder and review."""
