"""The two ways a run ends badly, shared by the run (``shards``) and where it runs (``executors``)."""

from __future__ import annotations


class RunError(RuntimeError):
    """A run that cannot start; the message says what to change (exit status 2)."""


class RunFailed(RunError):
    """A run that started but could not finish every shard; complete shards are kept (exit status 1)."""
