"""The shipped JSON schema (`fold_schema.json`) for the FOLD subset we read and write.

Validation with it needs the optional `jsonschema` package; without it `validate_schema` does nothing
and the structural checks of `check_fold` (always run) still catch what matters to us.
"""

from __future__ import annotations

import functools
import importlib.resources
import importlib.util
import itertools
import json
from typing import Any, cast

from .._exported import remembered
from ._errors import FoldFormatError

SCHEMA_FILE = "fold_schema.json"
# Schema errors collected before reporting the first (an invalid large file has millions).
MAX_ERRORS = 100


@functools.cache
def fold_schema() -> dict[str, Any]:
    """The JSON schema (draft-07) for the FOLD 1.2 subset origami_jax reads and writes."""
    resource = importlib.resources.files(cast(str, __package__))  # set: a module of a package
    text = resource.joinpath(SCHEMA_FILE).read_text(encoding="utf-8")
    return json.loads(text)


def has_jsonschema() -> bool:
    """Whether the optional `jsonschema` package is importable."""
    try:
        import jsonschema  # noqa: F401
    except ImportError:
        return False
    return True


def validate_schema_once(data: Any) -> None:
    """`validate_schema(data)`, unless a process of the same package found the same `data` valid
    (kept beside the compiled programs where a command keeps them: `remembered`). A command
    reading a FOLD file it read before then neither imports `jsonschema` (~0.3 s) nor validates.
    Invalid data raises every time; nothing is kept where nothing was checked (no `jsonschema`)."""
    if importlib.util.find_spec("jsonschema") is None:
        return
    try:
        remembered("fold_schema_valid", lambda: _checked(data), data)
    except _Unchecked:
        pass


class _Unchecked(Exception):
    """`validate_schema` could not check (`jsonschema` found but not importable): keep nothing."""


def _checked(data: Any) -> bool:
    if not validate_schema(data):
        raise _Unchecked
    return True


def validate_schema(data: Any) -> bool:
    """Validate decoded FOLD data against `fold_schema()` when `jsonschema` is installed.

    **Returns:** `True` if the schema was checked, `False` if `jsonschema` is not installed.

    **Raises:** `FoldFormatError` naming the offending key path and the schema's complaint.
    """
    if not has_jsonschema():
        return False
    import jsonschema

    validator = jsonschema.Draft7Validator(fold_schema())
    errors = sorted(
        itertools.islice(validator.iter_errors(data), MAX_ERRORS),
        key=lambda e: [str(p) for p in e.absolute_path],
    )
    if errors:
        error = errors[0]
        location = "".join(
            f"[{p}]" if isinstance(p, int) else (f".{p}" if i else str(p))
            for i, p in enumerate(error.absolute_path)
        )
        if len(errors) >= MAX_ERRORS:
            more = f" (and {MAX_ERRORS - 1} or more other problems)"
        else:
            more = f" (and {len(errors) - 1} more problem(s))" if len(errors) > 1 else ""
        message = error.message  # holds the offending value, which may be a whole array
        if len(message) > 300:
            message = message[:297] + "..."
        raise FoldFormatError(
            f"does not match the FOLD schema at {location or 'the top level'}: {message}{more}"
        )
    return True
