"""Exception classes of cliff_lhmp (raised by the native module)."""

from typing import Optional

__all__ = ["Rejected", "NoDaemon", "DaemonGone", "DeadlinePassed"]


class Rejected(ValueError):
    """The daemon refused the request.

    Attributes:
        status: the daemon's status name, e.g. "unknown-map", "bad-k",
            "history-too-short" (new statuses of newer daemons come through as they are).
        field: the value concerned ("map", "k", "dt", "time", ...) or None.
        agent: index of the history concerned, or None.
        row: row (within that history) concerned, or None.
        limit: the daemon's limit that was exceeded (0 when none).
    """

    def __init__(
        self,
        message: str,
        status: str,
        field: Optional[str] = None,
        agent: Optional[int] = None,
        row: Optional[int] = None,
        limit: int = 0,
    ) -> None:
        super().__init__(message)
        self.status = status
        self.field = field
        self.agent = agent
        self.row = row
        self.limit = limit

    def __reduce__(self):  # type: ignore[no-untyped-def]
        return (
            type(self),
            (str(self), self.status, self.field, self.agent, self.row, self.limit),
        )


class NoDaemon(ConnectionError):
    """No cliffd daemon serves the service (not started, stopped, or another --prefix)."""


class DaemonGone(ConnectionError):
    """The daemon died or shut down while the request was in flight."""


class DeadlinePassed(TimeoutError):
    """No response came within the client's deadline.

    Attributes:
        deadline: the deadline that passed (s).
    """

    def __init__(self, message: str, deadline: float = 0.0) -> None:
        super().__init__(message)
        self.deadline = deadline

    def __reduce__(self):  # type: ignore[no-untyped-def]
        return (type(self), (str(self), self.deadline))
