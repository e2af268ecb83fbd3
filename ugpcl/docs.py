"""Generated parts of README.md and docs/chapters/*.md, and the pictures in docs/img/.

    python -m ugpcl.docs tables   rewrite every generated block (make docs)
    python -m ugpcl.docs check    exit 1 when a generated block is stale (a test runs this)
    python -m ugpcl.docs images [SCENE ...]   render docs/img/<scene>.png for every (or the named) scene (make png)

A block is the text between ``<!-- BEGIN generated:KIND [SCENE] -->`` and ``<!-- END generated -->``;
KIND is ``scenes`` (the table of every scene), ``gallery`` (a thumbnail of each chapter's first scene),
``keys`` (one scene's keys), ``all-keys`` or ``params``.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from .cli import format_table
from .scenes import get, scenes

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs" / "chapters").glob("*.md"))]
PREVIEW_SIZE = (1280, 720)
"""Width and height of docs/img/<scene>.png (16:9, the size the README gallery and chapter pages show)."""
BLOCK = re.compile(r"(<!-- BEGIN generated:([\w-]+)(?: (\w+))? -->\n)(.*?)(<!-- END generated -->)", re.S)


def chapter_doc(scene) -> Path | None:
    """The page of the scene's stem, else of its longest stem prefix: space_colonization_cpu and
    space_colonization_skinned are documented on the space_colonization page."""
    chapters = ROOT / "docs" / "chapters"
    words = scene.stem.split("_")
    for n in range(len(words), 0, -1):
        stem = "_".join(words[:n])
        matches = sorted({*chapters.glob(f"*-{stem}.md"), *chapters.glob(f"*-{stem.replace('_', '-')}.md")})
        if matches:
            return matches[0]
    return None


def markdown_table(rows: list[dict]) -> str:
    columns = list(rows[0])
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(str(row[c]).replace("|", "\\|") for c in columns) + " |" for row in rows]
    return "\n".join(lines)


def scenes_table(relative_to: Path) -> str:
    rows = []
    for name, scene in scenes().items():
        doc = chapter_doc(scene)
        link = f"[{scene.stem}]({Path(*_relative(doc, relative_to))})" if doc else scene.stem
        rows.append({"scene": f"`{name}`", "what you see": scene.summary, "chapter": link})
    return markdown_table(rows)


GALLERY_COLUMNS = 4
GALLERY_WIDTH = 220
"""Thumbnails per row and their width in pixels: four fit GitHub's README column."""


def gallery(relative_to: Path) -> str:
    """A table of thumbnails, one per chapter page in page order (the page's first scene), each linking to its page."""
    firsts: dict[Path, str] = {}
    for name, scene in scenes().items():
        doc = chapter_doc(scene)
        if doc:
            firsts.setdefault(doc, name)
    cells = []
    for doc, name in sorted(firsts.items()):
        page = Path(*_relative(doc, relative_to)).as_posix()
        image = Path(*_relative(ROOT / "docs" / "img" / f"{name}.png", relative_to)).as_posix()
        title = doc.read_text().splitlines()[0].lstrip("# ")
        cells.append(f'[<img src="{image}" width="{GALLERY_WIDTH}" alt="{name}">]({page})<br>[{title}]({page})')
    cells += [""] * (-len(cells) % GALLERY_COLUMNS)
    rows = [cells[i : i + GALLERY_COLUMNS] for i in range(0, len(cells), GALLERY_COLUMNS)]
    lines = ["|" + " |" * GALLERY_COLUMNS, "|" + "---|" * GALLERY_COLUMNS]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def _relative(path: Path, start: Path) -> tuple[str, ...]:
    return Path(__import__("os").path.relpath(path, start)).parts


def keys_table(name: str) -> str:
    from ugpcl.viewer.app import keys_markdown

    return keys_markdown(get(name))


def all_keys() -> str:
    from ugpcl.viewer.app import MOUSE_HELP, SHARED_KEYS
    from ugpcl.viewer.views import view_class

    parts = ["Every scene:", "", markdown_table([{"key": f"`{k.key}`", "action": k.help} for k in SHARED_KEYS])]
    parts += ["", f"and the {MOUSE_HELP}.", ""]
    for name, scene in scenes().items():
        keys = view_class(scene).keys
        if keys:
            rows = [{"key": f"`{k.key}`", "action": k.help} for k in keys]
            parts += [f"`{name}`:", "", markdown_table(rows), ""]
    return "\n".join(parts).rstrip()


def params_table(name: str) -> str:
    scene = get(name)
    rows = scene.table()
    for row in rows:
        row["name"] = f"`{row['name']}`"
    limits = [f"- `{rule}`" for rule in scene.limits()]
    return "\n".join([markdown_table(rows), *(["", "Limits across parameters:", "", *limits] if limits else [])])


def render_block(kind: str, scene: str | None, path: Path) -> str:
    if kind == "scenes":
        return scenes_table(path.parent)
    if kind == "gallery":
        return gallery(path.parent)
    if kind == "all-keys":
        return all_keys()
    if kind == "keys":
        return keys_table(scene)
    if kind == "params":
        return params_table(scene)
    raise ValueError(f"{path}: unknown generated block {kind!r}")


def regenerate(path: Path) -> str:
    text = path.read_text()
    return BLOCK.sub(lambda m: m[1] + render_block(m[2], m[3], path) + "\n" + m[5], text)


def tables(check: bool = False) -> int:
    stale = []
    for path in DOCS:
        new = regenerate(path)
        if new != path.read_text():
            stale.append(path)
            if not check:
                path.write_text(new)
    if check and stale:
        print("stale generated blocks (run `make docs`): " + ", ".join(str(p.relative_to(ROOT)) for p in stale))
        return 1
    return 0


def images(names: list[str] | None = None) -> int:
    from ugpcl.viewer.offscreen import render_png

    from .runtime import Runtime

    runtime = Runtime()
    out = ROOT / "docs" / "img"
    rows = []
    for name, scene in scenes().items():
        if names and name not in names:
            continue
        preview = dict(scene.preview)
        steps = preview.pop("steps", 300)
        sim = scene.create(runtime, 0, **preview)
        for _ in range(steps):
            sim.step()
        render_png(scene, sim, out / f"{name}.png", PREVIEW_SIZE)
        rows.append({"scene": name, "steps": steps, "overrides": preview or "-", "picture": f"docs/img/{name}.png"})
        print(f"wrote docs/img/{name}.png", file=sys.stderr)
    print(format_table(rows))
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    command = argv[0] if argv else "tables"
    if command == "tables":
        return tables()
    if command == "check":
        return tables(check=True)
    if command == "images":
        return images(argv[1:])
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
