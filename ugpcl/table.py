"""Plain-text tables that fit the terminal: ``ugpcl list | info | params | bench`` and the chapter pages."""

from __future__ import annotations

import shutil
import textwrap


def terminal_width() -> int:
    """Columns of the terminal (``COLUMNS`` wins); 160 when the output is not a terminal."""
    return shutil.get_terminal_size(fallback=(160, 24)).columns


def format_table(rows: list[dict], columns: list[str] | None = None, width: int | None = None) -> str:
    """A plain-text table that fits ``width`` (default: the terminal): text left-aligned, numbers right-aligned,
    columns narrowed from the widest down and their cells wrapped at word boundaries; floats get 4 significant
    digits (or engineering form when large or small)."""
    if not rows:
        return "(no rows)"
    columns = columns or list(dict.fromkeys(k for row in rows for k in row))

    def cell(v) -> str:
        if isinstance(v, float):
            return f"{v:.3e}" if abs(v) >= 1e5 or (v != 0 and abs(v) < 1e-3) else f"{v:.4g}"
        return str(v)

    text = [[cell(row.get(c, "")) for c in columns] for row in rows]
    numeric = [all(isinstance(row.get(c), int | float) for row in rows if c in row) for c in columns]
    widths = [max(len(c), *(len(r[i]) for r in text)) for i, c in enumerate(columns)]
    # narrowest a column may get: the first (the names) stays whole; the others keep their header and words up to
    # 16 characters whole (longer words break)
    floors = [widths[0]] + [
        min(w, max(len(c), min(16, max(len(word) for r in text for word in r[i].split() or [""]))))
        for i, (c, w) in enumerate(zip(columns, widths, strict=True))
    ][1:]
    budget = (width or terminal_width()) - 2 * (len(columns) - 1)
    while sum(widths) > budget:
        i = max(range(len(widths)), key=lambda k: (widths[k] > floors[k], widths[k], k))  # the widest first
        if widths[i] <= floors[i]:
            break  # every column at its floor: let the line run long rather than lose text
        widths[i] -= 1

    def line(cells: list[str]) -> str:
        parts = [t.rjust(w) if num else t.ljust(w) for t, w, num in zip(cells, widths, numeric, strict=True)]
        return "  ".join(parts).rstrip()

    lines = [line(list(columns)), "  ".join("-" * w for w in widths)]
    for r in text:
        wrapped = [textwrap.wrap(t, w, break_on_hyphens=False) or [""] for t, w in zip(r, widths, strict=True)]
        for k in range(max(len(cell_lines) for cell_lines in wrapped)):
            lines.append(line([cell_lines[k] if k < len(cell_lines) else "" for cell_lines in wrapped]))
    return "\n".join(lines)
