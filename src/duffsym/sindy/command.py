"""CLI of duffsym.sindy (being written: see the open issue)."""
from __future__ import annotations


def register(sub) -> None:
    """No subcommand yet."""
