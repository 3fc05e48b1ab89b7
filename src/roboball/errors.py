"""User-facing errors.

Anything a user can cause (a bad file, a bad flag, a bad config value) raises
:class:`RoboballError` with a single-line message naming the file, the row or field,
and what is wrong.  The CLI prints that line and exits non-zero; it never shows a
traceback for these.
"""


class RoboballError(Exception):
    """An error caused by the user's input; its message is one line."""

    exit_code = 2

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))


class ConfigError(RoboballError):
    """A configuration file is missing, malformed or out of physical range."""


class SimulationError(RoboballError):
    """A simulation diverged, penetrated too deep, or produced non-finite values."""

    exit_code = 3
