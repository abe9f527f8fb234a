"""``python -m hil``: the ``fowt`` command."""

from hil.cli.fowt import entry

entry()
