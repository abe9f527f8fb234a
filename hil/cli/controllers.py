"""The ``fowt controllers`` command: every controller kind the bench finds.

Registered on the ``fowt`` Typer app by :func:`register`. The kinds come from
:func:`controller.registry.list_kinds`: the shipped table, then the installed plug-ins (the
entry points of ``fowt_hil.controllers``), each loaded so that one that cannot be used says
why; with ``--core module:attribute`` also that ``kind = "python"`` core.
"""

from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table
from rich.text import Text

from hil.cli import common as cli_common


def register(app: typer.Typer, console: Console) -> None:
    """Add ``controllers`` to the ``fowt`` app."""

    @app.command("controllers", short_help="List the controller kinds found (shipped, plug-ins).")
    def controllers_cmd(
        core: Annotated[
            str | None,
            typer.Option(
                "--core",
                help='Also load this kind = "python" core (package.module:attribute).',
            ),
        ] = None,
    ) -> None:
        """List every controller kind a scenario may name: shipped ones, the installed
        plug-ins (entry points of fowt_hil.controllers) and, with --core, a python core.

        Exits 1 when a plug-in found cannot be used (the table says why), 2 when --core
        cannot be loaded.
        """
        from controller.registry import ENTRY_POINT_GROUP, list_kinds  # noqa: PLC0415

        rows = list_kinds(core)
        if core is not None and rows[-1].error:
            cli_common.fail(rows[-1].error)
        t = Table(title=Text("controller kinds: [controller] kind"))
        for col in ("kind", "source", "settings", "design", "description"):
            t.add_column(col)
        for r in rows:
            t.add_row(
                Text(r.name),
                Text(r.source),
                Text(r.settings.rsplit(".", 1)[-1] or "-"),
                "yes" if r.design else "-",
                Text(r.description) if not r.error else Text(f"cannot be used: {r.error}", "red"),
            )
        console.print(t)
        console.print(
            f'Your own: a distribution registering an entry point in "{ENTRY_POINT_GROUP}", or '
            'kind = "python" with core = "package.module:attribute" '
            "(docs/guide/own-controller.md).",
            markup=False,
        )
        if any(r.error for r in rows):
            raise typer.Exit(1)
