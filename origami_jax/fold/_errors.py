"""The one error type of the FOLD sub-package."""


class FoldFormatError(ValueError):
    """A FOLD file (or dictionary) that cannot be read, or that asks for something unsupported.

    Every message says what is wrong, where (key, edge, face or frame index) and, where it can, how to
    fix it. It derives from `ValueError`, so callers that already catch bad input keep working.
    """
