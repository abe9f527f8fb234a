"""The ``fowt`` command line: one module per command family."""
