"""Tables of the result pages: rows of strings as a markdown table or as aligned plain text.

``align`` names each column's alignment by one letter, ``l`` (left) or ``r`` (right), in
order; columns past its end are right-aligned. ``"l"`` (the default): the first column left,
the numbers after it right; ``""``: every column right.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence


def _letters(align: str, n: int) -> str:
    return align[:n].ljust(n, "r")


def markdown_table(
    head: Sequence[str], rows: Iterable[Sequence[str]], align: str = "l"
) -> list[str]:
    """A markdown table, as lines: the header, the alignment rule, one line per row."""
    rule = "".join("---|" if a == "l" else "---:|" for a in _letters(align, len(head)))
    lines = ["| " + " | ".join(head) + " |", "|" + rule]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def text_table(head: Sequence[str], rows: Sequence[Sequence[str]], align: str = "l") -> str:
    """A plain-text table: columns padded to their widest cell, two spaces between them."""
    table = [head, *rows]
    widths = [max(len(line[i]) for line in table) for i in range(len(head))]
    letters = _letters(align, len(head))
    return "\n".join(
        "  ".join(
            cell.ljust(w) if a == "l" else cell.rjust(w)
            for cell, w, a in zip(line, widths, letters, strict=True)
        )
        for line in table
    )
