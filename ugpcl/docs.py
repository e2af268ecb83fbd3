"""Generated parts of README.md and docs/chapters/*.md, and the pictures in docs/img/.

    python -m ugpcl.docs tables   rewrite every generated block (make docs)
    python -m ugpcl.docs check    exit 1 when a generated block is stale (a test runs this)
    python -m ugpcl.docs images [SCENE ...]   render docs/img/<scene>.png for every (or the named) scene (make png)
    python -m ugpcl.docs animations [SCENE ...]   record docs/img/<scene>.webp, the loop of each chapter page's
                                                  picture scene (or of the named ones) (make anim)
    python -m ugpcl.docs animations --gpu [SCENE ...]   on a GPU: record docs/img/gpu/<scene>.webp, the flagship
                                                  scenes at scale (``Scene.at_scale``) (make anim-gpu)

A block is the text between ``<!-- BEGIN generated:KIND [SCENE] -->`` and ``<!-- END generated -->``;
KIND is ``scenes`` (the table of every scene), ``gallery`` (a thumbnail of each chapter's first scene),
``keys`` (one scene's keys), ``all-keys``, ``params``, ``animation`` (the page's loop and what it shows),
``gpu-gallery`` (the loops at scale) or ``gpu-animation`` (one scene's loop at scale).
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

from .registry import get, scenes
from .scene import Animation
from .table import format_table

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs" / "chapters").glob("*.md"))]
PREVIEW_SIZE = (1280, 720)
"""Width and height of docs/img/<scene>.png (16:9, the size the README gallery and chapter pages show)."""
BLOCK = re.compile(r"(<!-- BEGIN generated:([\w-]+)(?: (\w+))? -->\n)(.*?)(<!-- END generated -->)", re.S)


CHAPTERS: dict[str, tuple[int, str]] = {
    "procedural_modeling": (1, "Procedural modeling (vol.1 ch.1)"),
    "compute_intro": (2, "Getting started with compute (vol.1 ch.2)"),
    "boids": (3, "Boids on the GPU (vol.1 ch.3)"),
    "stable_fluids_2d": (4, "Stable fluids in 2D (vol.1 ch.4)"),
    "stable_fluids_3d": (4, "Stable fluids in 3D (vol.1 ch.4)"),
    "sph_2d": (5, "SPH fluid 2D (vol.1 ch.5)"),
    "grass": (6, "Geometry shaders: pyramids and grass (vol.1 ch.6)"),
    "marching_cubes": (7, "Marching cubes, starting with atmosphere (vol.1 ch.7)"),
    "mcmc": (8, "3D spatial sampling with MCMC (vol.1 ch.8)"),
    "multiplane_projection": (9, "MultiPlane perspective projection (vol.1 ch.9)"),
    "projection_spray": (10, "Projection spray (vol.1 ch.10)"),
    "cellular_growth": (11, "GPU-based cellular growth (vol.3 ch.4)"),
    "space_colonization": (12, "GPU-based space colonization (vol.4 ch.1)"),
    "kleinian": (13, "Limit sets of Kleinian groups (vol.4 ch.2)"),
    "cloth": (14, "GPU cloth simulation (vol.4 ch.3)"),
    "star_glow": (15, "StarGlow (vol.4 ch.4)"),
    "ear_clipping": (16, "Triangulation by ear clipping (vol.4 ch.5)"),
    "tessellation": (17, "Tessellation & displacement (vol.4 ch.6)"),
    "poisson_disk": (18, "Poisson disk sampling (vol.4 ch.7)"),
}
"""The chapter pages in the books' order: {stem: (page number, title)}. The page of ``stem`` is
``docs/chapters/NN-<stem with hyphens>.md`` and its first line ``# <title>``; two stems of one book chapter share
its number (the 2D and 3D fluids). A new chapter gets its number here (docs/adding-a-chapter.md)."""


def chapter_page(stem: str) -> Path:
    """Where the page of chapter ``stem`` (a key of CHAPTERS) lives."""
    number, _ = CHAPTERS[stem]
    return ROOT / "docs" / "chapters" / f"{number:02d}-{stem.replace('_', '-')}.md"


def chapter_doc(scene) -> Path | None:
    """The page of the scene's stem in CHAPTERS, else of its longest stem prefix there (space_colonization_cpu and
    space_colonization_skinned are documented on the space_colonization page); None for a scene of no chapter (one
    loaded from UGPCL_SCENES) or where the page is absent (an installed package has no docs/)."""
    words = scene.stem.split("_")
    for n in range(len(words), 0, -1):
        stem = "_".join(words[:n])
        if stem in CHAPTERS:
            page = chapter_page(stem)
            return page if page.is_file() else None
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

    parts = ["Every scene:", "", markdown_table([{"key": f"`{k.key}`", "action": k.help} for k in SHARED_KEYS])]
    parts += ["", f"and the {MOUSE_HELP}. A scene's own keys are on its chapter page, and"]
    parts += ["`ugpcl-view SCENE --keys` prints them."]
    return "\n".join(parts).rstrip()


def params_table(name: str) -> str:
    scene = get(name)
    rows = scene.table()
    for row in rows:
        row["name"] = f"`{row['name']}`"
    limits = [f"- `{rule}`" for rule in scene.limits()]
    return "\n".join([markdown_table(rows), *(["", "Limits across parameters:", "", *limits] if limits else [])])


# {{{ animations: a short loop of each chapter page's picture scene, recorded as `ugpcl run --video x.webp` does

ANIMATION_SIZE = (480, 270)
"""Width and height of docs/img/<scene>.webp (16:9 as the picture, small enough for a page)."""
ANIMATION_FPS = 15
"""Playback rate of the loops: a loop of ``Animation``'s default 45 frames lasts 3 s."""
PICTURE = re.compile(r"^!\[(\w+)\]\(\.\./img/(\w+)\.png\)$", re.M)


def animated() -> dict[str, Animation]:
    """{scene: its loop} for every scene that declares one (``Scene.animation``): each chapter page's picture."""
    return {name: scene.animation for name, scene in scenes().items() if scene.animation}


def page_scenes() -> dict[Path, str]:
    """Each chapter page and the scene of its picture, the first ``![scene](../img/scene.png)`` that names one."""
    known = scenes()
    found = {}
    for doc in DOCS[1:]:
        names = [m[2] for m in PICTURE.finditer(doc.read_text()) if m[1] == m[2] and m[2] in known]
        if names:
            found[doc] = names[0]
    return found


def animation_block(name: str, path: Path) -> str:
    """The page's loop under its picture, and a line on how it was recorded and what it shows."""
    anim = get(name).animation
    image = Path(*_relative(ROOT / "docs" / "img" / f"{name}.webp", path.parent)).as_posix()
    if anim.start is None:
        start = f"step {get(name).preview.get('steps', 300)} (the picture's)"
    else:
        start = "the start" if anim.start == 0 else f"step {anim.start}"
    every = f"{anim.every} step{'s' * (anim.every > 1)}"
    return (
        f"![{name}, animated]({image})\n\n"
        f"Loop ({anim.frames} frames at {ANIMATION_FPS} fps, {every} a frame from {start}; `make anim`): {anim.shows}."
    )


def record_animation(
    runtime, name: str, path: Path, anim: Animation | None = None, at_scale: dict | None = None, size=ANIMATION_SIZE
) -> int:
    """Record the loop of scene ``name`` (its ``Scene.animation``, or ``anim``) to ``path``: the run loop and
    recorder of ``ugpcl run --video`` (``run_steps`` with a frame callback, ``Recorder``), drawn by
    ``offscreen.render`` through one view and camera. ``at_scale``: these parameters instead of the preview's, from
    ``anim.start`` (or the start). Returns the number of frames."""
    from ugpcl.viewer.offscreen import context, render
    from ugpcl.viewer.record import Recorder
    from ugpcl.viewer.views import create_view

    from .run import run_steps

    scene = get(name)
    anim = anim or scene.animation
    preview = {**scene.preview, **anim.overrides} if at_scale is None else {"steps": 0, **at_scale, **anim.overrides}
    steps = preview.pop("steps", 300)
    sim = scene.create(runtime, 0, **preview)
    dt = scene.simulation.default_dt
    start = steps if anim.start is None else anim.start
    if start:  # (run_steps checks the state it ends on: the poisson_disk sampler's lone first point has nn_dist inf)
        run_steps(sim, start, dt, quiet=True)
    view = create_view(scene, context(), sim)
    camera = view.png_camera()
    yaw = getattr(camera, "yaw", None)
    if anim.swing and yaw is None:
        raise ValueError(f"{name}: swing needs an orbit camera, the view has a {type(camera).__name__}")
    with Recorder(path, fps=ANIMATION_FPS, webp_quality=anim.quality) as recorder:

        def frame():
            if anim.swing:
                camera.yaw = yaw + anim.swing * math.sin(2 * math.pi * recorder.frames / anim.frames)
            recorder.add(render(scene, sim, size, view, camera))

        run_steps(sim, (anim.frames - 1) * anim.every, dt, quiet=True, frame=(anim.every, frame))
    return recorder.frames


GPU_ANIMATION_SIZE = (640, 360)
"""The loops at scale (docs/img/gpu/<scene>.webp): larger than the chapter loops, a million of anything needs pixels."""
GPU_LOOPS = ROOT / "docs" / "img" / "gpu"


def at_scale_loops() -> dict[str, Animation]:
    """{scene: its loop at scale} for every flagship scene that declares one (``AtScale.loop``)."""
    return {name: s.at_scale.loop for name, s in scenes().items() if s.at_scale is not None and s.at_scale.loop}


def gpu_gallery(relative_to: Path) -> str:
    """The loops at scale in a row, each with its size and what it shows (README and the chapter pages)."""
    cells = []
    for name, loop in at_scale_loops().items():
        image = Path(*_relative(GPU_LOOPS / f"{name}.webp", relative_to)).as_posix()
        cells.append((f'<img src="{image}" width="{GALLERY_WIDTH}" alt="{name} at scale">', f"{name}: {loop.shows}"))
    lines = ["|" + " |" * len(cells), "|" + "---|" * len(cells)]
    return "\n".join(
        lines + ["| " + " | ".join(c[0] for c in cells) + " |", "| " + " | ".join(c[1] for c in cells) + " |"]
    )


def gpu_animation_block(name: str, path: Path) -> str:
    """A chapter page's loop at scale and how it was made."""
    scene = get(name)
    loop = scene.at_scale.loop
    image = Path(*_relative(GPU_LOOPS / f"{name}.webp", path.parent)).as_posix()
    sizes = ", ".join(f"{k}={v}" for k, v in scene.at_scale.gpu.items())
    start = f" from step {loop.start}" if loop.start else ""
    return (
        f"![{name} at scale]({image})\n\nAt scale on the lent GPU ({sizes}; {loop.frames} frames, {loop.every} "
        f"step{'s' * (loop.every > 1)} a frame{start}; `make anim-gpu` on a GPU machine): {loop.shows}."
    )


def gpu_animations(names: list[str] | None = None) -> int:
    """Record docs/img/gpu/<scene>.webp for every (or the named) flagship scene at its GPU sizes; a GPU only."""
    from .runtime import Runtime

    loops = at_scale_loops()
    unknown = set(names or ()) - set(loops)
    if unknown:
        print(f"animations --gpu: no loop at scale for {', '.join(sorted(unknown))}", file=sys.stderr)
        return 2
    runtime = Runtime()
    if not runtime.is_gpu:
        print(f"animations --gpu: {runtime.label} is not a GPU (the loops are a million elements); choose one "
              "with --device or UGPCL_DEVICE", file=sys.stderr)  # fmt: skip
        return 2
    GPU_LOOPS.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, loop in loops.items():
        if names and name not in names:
            continue
        path = GPU_LOOPS / f"{name}.webp"
        frames = record_animation(runtime, name, path, loop, get(name).at_scale.gpu, GPU_ANIMATION_SIZE)
        rows.append({"scene": name, "frames": frames, "KB": path.stat().st_size // 1024})
        print(f"wrote {path.relative_to(ROOT)} ({frames} frames, {path.stat().st_size // 1024} KB)", file=sys.stderr)
    print(format_table(rows))
    return 0


def animations(names: list[str] | None = None) -> int:
    """Record docs/img/<scene>.webp for every (or the named) chapter page's picture scene."""
    from .runtime import Runtime

    if names and names[0] == "--gpu":
        return gpu_animations(names[1:])
    shown = sorted(page_scenes().values())
    unknown = set(names or ()) - set(shown)
    if unknown:
        print(f"animations: no chapter page shows {', '.join(sorted(unknown))} as its picture", file=sys.stderr)
        return 2
    runtime = Runtime()
    rows = []
    for name in shown:
        if names and name not in names:
            continue
        path = ROOT / "docs" / "img" / f"{name}.webp"
        frames = record_animation(runtime, name, path)
        anim, size = get(name).animation, path.stat().st_size
        rows.append(
            {
                "scene": name,
                "start": "preview" if anim.start is None else anim.start,
                "every": anim.every,
                "frames": frames,
                "KB": size // 1024,
            }
        )
        print(f"wrote {path.relative_to(ROOT)} ({frames} frames, {size // 1024} KB)", file=sys.stderr)
    print(format_table(rows))
    return 0


# }}}


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
    if kind == "animation":
        return animation_block(scene, path)
    if kind == "gpu-gallery":
        return gpu_gallery(path.parent)
    if kind == "gpu-animation":
        return gpu_animation_block(scene, path)
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
    if command == "animations":
        return animations(argv[1:])
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
