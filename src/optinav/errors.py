"""The one exception type users see.

Every bad input ends in an :class:`OptinavError` whose message is one line naming the cause and what
to do; the CLI prints it without a traceback (``--debug`` shows one).
"""


class OptinavError(ValueError):
    """Bad input or an impossible request; the message is a one-line cause and remedy."""

    def __init__(self, cause: str, remedy: str | None = None):
        msg = cause if remedy is None else f"{cause}; {remedy}"
        super().__init__(" ".join(msg.split()))
        self.cause = cause
        self.remedy = remedy


class SwappedAxes(OptinavError):
    """An :class:`OptinavError` that already names swapped or flipped axes or triads as a likely cause, so that a
    caller adds no hint of its own about swapped columns."""


class Note(UserWarning):
    """Something a reader or a step did that the user should know (a line left out, a rate taken from the time
    column): shown by the CLI as ``optinav: note: …``; from Python, an ordinary warning that can be filtered."""


def message_kind(category) -> str:
    """How the CLI names a warning of ``category``: ``"note"`` for a :class:`Note`, else ``"warning"``."""
    return "note" if isinstance(category, type) and issubclass(category, Note) else "warning"
