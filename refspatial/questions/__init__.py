"""The question engine: referring expressions, programs, phrasings and QA families."""

from .generate import FAMILIES, questions_for_view
from .program import OPS, ProgramError, count_steps, execute

__all__ = ["FAMILIES", "OPS", "ProgramError", "count_steps", "execute", "questions_for_view"]
