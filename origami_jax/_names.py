"""Suggestions for a misspelt name: "did you mean …?" in the one-line refusals of the command line
and the sweep's settings (plain Python: the command line imports it before JAX)."""

import difflib
from collections.abc import Iterable


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """``" (did you mean X?)"`` for the choice most like `name` (`difflib`'s similarity, at least
    0.6), or ``""`` when none is close."""
    near = difflib.get_close_matches(name, list(choices), n=1)
    return f" (did you mean {near[0]}?)" if near else ""
