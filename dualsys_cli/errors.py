"""How the CLI reports errors a user can cause: one line on stderr, exit code 2, no traceback."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import typer

USER_ERRORS: tuple[type[Exception], ...] = (ValueError, FileNotFoundError, KeyError, PermissionError)
"""Exception types that mean bad input rather than a bug; library code raises these (or subclasses)."""


@contextmanager
def user_errors() -> Iterator[None]:
    """Turn a user error raised inside the block into `error: <message>` and exit code 2."""
    try:
        yield
    except USER_ERRORS as exc:
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        typer.secho(f"error: {message}", err=True, fg=typer.colors.RED)
        raise typer.Exit(code=2) from None
