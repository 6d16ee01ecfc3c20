"""Griffe extension of the documentation build: read the package's Markdown docstrings as written.

The docstrings open their lists right after a line of text (``**Fields:**`` then ``- `x`: ...``), as
Markdown renderers on GitHub and in notebooks accept; Python-Markdown, which MkDocs uses, needs a
blank line before a list and would run the items into the paragraph. This extension inserts that
blank line when the documentation is built, so the docstrings stay as they are.
"""

import re

import griffe

_ITEM = re.compile(r"^\s*(?:[-*+]|\d+[.)])\s+\S")
_FENCE = re.compile(r"^\s*(```|~~~)")


def blank_line_before_lists(text: str) -> str:
    """`text` with a blank line before every list that follows a line of text directly (code
    fences left alone)."""
    out: list[str] = []
    in_list = in_fence = False
    for line in text.splitlines():
        if _FENCE.match(line):
            in_fence = not in_fence
        elif not in_fence:
            if not line.strip():
                in_list = False
            elif _ITEM.match(line):
                if not in_list and out and out[-1].strip():
                    out.append("")
                in_list = True
        out.append(line)
    return "\n".join(out)


class MarkdownLists(griffe.Extension):
    """Apply `blank_line_before_lists` to every docstring griffe loads."""

    def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = blank_line_before_lists(obj.docstring.value)
