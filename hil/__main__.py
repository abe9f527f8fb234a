"""``python -m hil``: the ``fowt`` command."""

from hil.cli import main

main()
