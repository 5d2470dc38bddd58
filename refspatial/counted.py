"""Counts in messages: "1 shard", "3 shards", "1 failure"."""

from __future__ import annotations


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``, with the noun's plural (``noun + "s"`` unless given) when n != 1."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
