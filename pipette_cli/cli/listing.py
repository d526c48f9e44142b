"""Listings that fit the terminal: ``tasks list``, ``tasks suites``, ``assets list``, ``data inspect``, ``data stats``.

A listing is rows of cells under named columns. Key columns (ids, names, counts) are never cut;
text columns (an instruction, an outcome, a range of values) wrap between words. When the key
columns and a readable width of every text column fit the terminal, the listing is a table;
otherwise each row is stacked: its key cells on one line (aligned as columns where they fit,
else wrapped between cells), each text cell below them, indented and wrapped. The layout is
chosen when the listing is printed, for the width of the console it is printed on.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from rich.cells import cell_len
from rich.console import Console, ConsoleOptions, RenderResult
from rich.table import Table
from rich.text import Text

Cell = str | Text
"""A cell: plain text (never read as markup, so ``[x]`` in an instruction stays as written) or styled :class:`Text`."""

INDENT = 4
"""Indent of the text cells under a stacked row's key cells."""
GAP = 2
"""Spaces between the key cells of a stacked row."""
TABLE_OVERHEAD = 3
"""Cells a table column costs besides its text: one border and two of padding (plus one border per table)."""


@dataclass(frozen=True)
class Column:
    """One column of a listing.

    Attributes:
        header: The column's name.
        wrap: A text column (wraps between words) rather than a key column (never cut).
        justify: Alignment of the column's cells (``right`` for counts).
        min_width: Narrowest a text column may get in the table layout before the rows are stacked.
    """

    header: str
    wrap: bool = False
    justify: Literal["left", "right"] = "left"
    min_width: int = 30


def _text(cell: Cell) -> Text:
    return cell.copy() if isinstance(cell, Text) else Text(cell)


def _wrapped(console: Console, text: Text, width: int, indent: int) -> list[Text]:
    """``text`` wrapped between words (a word wider than the line is folded) to ``width`` cells, each
    line after ``indent`` spaces."""
    out = []
    for line in text.wrap(console, max(width - indent, 1), overflow="fold"):
        line.rstrip()
        out.append(Text(" " * indent) + line if indent else line)
    return out


class Listing:
    """Rows under columns, printed as a table or stacked per row, whichever the width allows.

    Example: ``out_console.print(Listing("3 tasks", [Column("id"), Column("instruction", wrap=True)], rows))``
    """

    def __init__(self, title: str, columns: Sequence[Column], rows: Sequence[Sequence[Cell]]) -> None:
        if all(column.wrap for column in columns):
            raise ValueError(f"listing {title!r} needs a key column (one that does not wrap)")
        if any(len(row) != len(columns) for row in rows):
            raise ValueError(f"every row of listing {title!r} needs {len(columns)} cells")
        self.title = title
        self.columns = list(columns)
        self.rows = [[_text(cell) for cell in row] for row in rows]

    def _natural(self, i: int) -> int:
        """Width of column ``i`` with nothing wrapped."""
        return max([cell_len(self.columns[i].header), *(row[i].cell_len for row in self.rows)])

    def fits_table(self, width: int) -> bool:
        """True when the key columns whole and each text column at its ``min_width`` (or less, if all
        its cells are narrower) fit in ``width`` cells as a table."""
        need = TABLE_OVERHEAD * len(self.columns) + 1
        for i, column in enumerate(self.columns):
            need += min(self._natural(i), column.min_width) if column.wrap else self._natural(i)
        return need <= width

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        width = options.max_width
        yield from _wrapped(console, Text(self.title, style="table.title"), width, 0)
        if self.fits_table(width):
            yield self._table()
        else:
            yield from self._stacked(console, width)

    def _table(self) -> Table:
        table = Table()
        for column in self.columns:
            table.add_column(column.header, justify=column.justify, no_wrap=not column.wrap, overflow="fold")
        for row in self.rows:
            table.add_row(*row)
        return table

    def _stacked(self, console: Console, width: int) -> RenderResult:
        keys = [i for i, c in enumerate(self.columns) if not c.wrap]
        texts = [i for i, c in enumerate(self.columns) if c.wrap]
        widths = {i: self._natural(i) for i in keys}
        aligned = sum(widths.values()) + GAP * (len(keys) - 1) <= width
        labelled = len(texts) > 1  # one text column goes unnamed under its rows

        def wrapped(text: Text, indent: int) -> list[Text]:
            return _wrapped(console, text, width, indent)

        def key_lines(cells: list[Text]) -> list[Text]:
            """The key cells on one line, aligned as columns where they all fit; else as many as fit
            on each line, the lines after the first indented (a cell is only folded if it is wider
            than the terminal)."""
            if aligned:
                cells = [cell.copy() for cell in cells]
                for i, cell in zip(keys, cells, strict=True):
                    cell.align(self.columns[i].justify, widths[i])
                return wrapped(Text(" " * GAP).join(cells), 0)
            lines: list[Text] = []
            for cell in cells:
                if lines and lines[-1].cell_len + GAP + cell.cell_len <= width:
                    lines[-1] = lines[-1] + Text(" " * GAP) + cell
                else:
                    lines.append(Text(" " * INDENT) + cell if lines else cell.copy())
            return [part for line in lines for part in wrapped(line, 0)]

        yield from key_lines([Text(self.columns[i].header, style="bold dim") for i in keys])
        if texts and not labelled:
            yield from wrapped(Text(self.columns[texts[0]].header, style="bold dim"), INDENT)
        for row in self.rows:
            cells = [row[i] for i in keys]
            cells[0] = cells[0].copy()
            cells[0].stylize("bold")  # where each row starts
            yield from key_lines(cells)
            for i in texts:
                if not row[i].plain:
                    continue
                cell = Text(f"{self.columns[i].header}: ", style="dim") + row[i] if labelled else row[i]
                yield from wrapped(cell, INDENT)
