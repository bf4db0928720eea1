"""The one shape of a refusal: an exception that stands for one human line per problem."""

from __future__ import annotations

__all__ = ["Problems"]


class Problems(Exception):
    """``problems`` holds one line each; the message joins them with ``joiner``."""

    joiner = "\n"

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__(self.joiner.join(problems))
