"""``python -m flexlink`` runs the command line (see flexlink.cli)."""

from .cli import command

command()
