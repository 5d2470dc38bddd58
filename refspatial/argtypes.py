"""Argument types shared by the command line's subcommands."""

from __future__ import annotations

import argparse
from typing import Callable


def at_least(minimum: float, kind: type = int) -> Callable[[str], float]:
    """An argparse type accepting numbers of ``kind`` no smaller than ``minimum``."""

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a{'n integer' if kind is int else ' number'}, got {text}")
        if not value >= minimum:
            raise argparse.ArgumentTypeError(f"expected a number >= {minimum}, got {text}")
        return value

    return parse
