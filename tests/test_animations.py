"""The chapter pages' loops (``python -m ugpcl.docs animations``, ``make anim``): every page embeds the animated WebP
of its picture scene, recorded through ``ugpcl run --video``'s path, and the file shows something that moves."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import foreground, most_common_colour
from PIL import Image

from ugpcl.docs import ANIMATION_SIZE, GPU_ANIMATION_SIZE, GPU_LOOPS, ROOT, animated, at_scale_loops, page_scenes
from ugpcl.scene import Animation

PAGES = page_scenes()
IMG = ROOT / "docs" / "img"
FILE_LIMIT, TOTAL_LIMIT = 400 * 1024, 6 * 1024 * 1024
"""Bytes per loop and for all of them: a page stays light to load, the repository small."""


def frames_of(path, size=ANIMATION_SIZE) -> tuple[list[np.ndarray], int | None]:
    """Every frame of an animated WebP as (H, W, 3) uint8, and its loop count (0: forever)."""
    with Image.open(path) as image:
        assert image.format == "WEBP" and image.size == size, f"{path.name}: {image.format} {image.size}"
        frames = []
        for k in range(image.n_frames):
            image.seek(k)
            frames.append(np.asarray(image.convert("RGB")))
        return frames, image.info.get("loop")


def test_every_page_has_a_loop_of_its_picture_scene():
    assert len(PAGES) == len(list((ROOT / "docs" / "chapters").glob("*.md"))), "a chapter page shows no scene picture"
    assert set(animated()) == set(PAGES.values()), "the scenes with an animation and the pages' picture scenes differ"


@pytest.mark.parametrize("page", list(PAGES), ids=lambda p: p.stem)
def test_page_embeds_its_loop_under_its_picture(page):
    name, text = PAGES[page], page.read_text()
    assert f"<!-- BEGIN generated:animation {name} -->" in text, f"{page.name}: no animation block for {name}"
    picture, loop = text.index(f"](../img/{name}.png)"), text.find(f"](../img/{name}.webp)")
    assert picture < loop, f"{page.name}: the loop of {name} is not embedded after its picture"


@pytest.mark.parametrize("name", sorted(animated()))
def test_loop_is_animated_and_shows_the_scene_moving(name):
    """Animated (the recorded frames, less those libwebp folds into an equal one before), looping forever, at
    ANIMATION_SIZE; no frame is empty (more than 0.3 % of it differs from its most common colour, the preview test's
    rule) and the scene visibly changes: from frame to frame in most steps of the loop, and in some frame against the
    first by more than 0.5 % of the frame."""
    path = IMG / f"{name}.webp"
    assert path.exists(), f"{path.name} missing: run make anim"
    frames, loop = frames_of(path)
    recorded = animated()[name].frames
    # folds only where nothing changed: the ear list and the Poisson sampler once they are complete
    assert 0.75 * recorded <= len(frames) <= recorded, f"{path.name}: {len(frames)} frames of {recorded} recorded"
    assert loop == 0, f"{path.name}: loop count {loop}, not 0 (forever)"
    for k, pixels in enumerate(frames):
        share = foreground(pixels, most_common_colour(pixels)).mean()
        assert share > 0.003, f"{path.name} frame {k}: only {share:.2%} of it differs from its background"
    # a visible change: more than 40 levels in more than 0.1 % of the pixels (lossy noise stays far below 40)
    frames = [f.astype(np.int16) for f in frames]
    moved = [(np.abs(a - b).max(axis=-1) > 40).mean() > 0.001 for a, b in zip(frames[:-1], frames[1:], strict=True)]
    assert np.mean(moved) > 0.5, f"{path.name}: only {sum(moved)} of {len(moved)} frame steps show motion"
    whole = max((np.abs(frames[0] - f).max(axis=-1) > 40).mean() for f in frames)
    assert whole > 0.005, f"{path.name}: no frame differs from the first in more than {whole:.2%} of the pixels"


GPU_LOOP_LIMIT = 3 * 2**20
"""Bytes per loop at scale (the issue's budget: a million dots compress poorly)."""


@pytest.mark.parametrize("name", sorted(at_scale_loops()))
def test_gpu_loop_is_animated_small_and_shows_the_scene_moving(name):
    """docs/img/gpu/<scene>.webp (``make anim-gpu``, recorded on the lent GPU at the scene's AtScale sizes): under 3 MB,
    at GPU_ANIMATION_SIZE, looping, no empty frame and visible motion (the chapter loops' rules)."""
    path = GPU_LOOPS / f"{name}.webp"
    assert path.exists(), f"{path.name} missing: make anim-gpu on a GPU machine"
    assert path.stat().st_size <= GPU_LOOP_LIMIT, f"{path.name}: {path.stat().st_size // 1024} KB"
    frames, loop = frames_of(path, GPU_ANIMATION_SIZE)
    assert loop == 0 and len(frames) >= 0.75 * at_scale_loops()[name].frames, f"{path.name}: {len(frames)} frames"
    for k, pixels in enumerate(frames):
        share = foreground(pixels, most_common_colour(pixels)).mean()
        assert share > 0.003, f"{path.name} frame {k}: only {share:.2%} of it differs from its background"
    frames = [f.astype(np.int16) for f in frames]
    whole = max((np.abs(frames[0] - f).max(axis=-1) > 40).mean() for f in frames)
    assert whole > 0.005, f"{path.name}: no frame differs from the first in more than {whole:.2%} of the pixels"


def test_loops_stay_small():
    sizes = {p.name: p.stat().st_size for p in (IMG / f"{name}.webp" for name in animated()) if p.exists()}
    large = {k: f"{v // 1024} KB" for k, v in sizes.items() if v > FILE_LIMIT}
    assert not large, f"loops over {FILE_LIMIT // 1024} KB: {large}"
    assert sum(sizes.values()) <= TOTAL_LIMIT, f"all loops together: {sum(sizes.values()) / 2**20:.1f} MB"


@pytest.mark.gl
def test_record_animation_replays_the_ear_list(runtime, gl, tmp_path):
    """The docs path itself: ear_clipping's loop reveals 4 ears a frame, from none to the whole glyph, so the first
    frame shows the outlines only and the last the filled glyph; equal frames at the end are folded by libwebp."""
    from ugpcl.docs import record_animation

    path = tmp_path / "ear_clipping.webp"
    assert record_animation(runtime, "ear_clipping", path) == animated()["ear_clipping"].frames
    frames, loop = frames_of(path)
    assert loop == 0 and [p.name for p in tmp_path.iterdir()] == ["ear_clipping.webp"]
    lit = [foreground(f, (0.0, 0.0, 0.0), 40).mean() for f in frames]  # the view's black background
    # outlines and the ear-list markers light about 4 % of the frame, the filled glyph about 12 %
    assert lit[-1] > 2 * lit[0], f"filled glyph {lit[-1]:.2%} vs outlines {lit[0]:.2%}"
    assert np.all(np.diff(lit) > -0.005), "the fill shrank between frames"  # ears are only ever added


@pytest.mark.gl
def test_a_swing_turns_the_camera_and_comes_back(runtime, gl, tmp_path, monkeypatch):
    """multiplane_projection does not change with time: its loop swings the orbit camera one sine period, so the
    frames differ and the loop's end meets its start (the frame after the last would be the first again). Faces at
    256 x 128 rather than the book's 1024 x 512 (each step renders them again): the swing moves the room's edges by
    as many pixels (the measures below agree within 2 %) for 1/16 of the kernel work."""
    import ugpcl.docs as docs

    anim = Animation(
        animated()["multiplane_projection"].shows, frames=8, swing=30.0, overrides={"face_resolution": (256, 128)}
    )
    path = tmp_path / "m.webp"
    assert docs.record_animation(runtime, "multiplane_projection", path, anim) == 8
    frames, _ = frames_of(path)
    assert len(frames) == 8
    step = [np.abs(a.astype(int) - b).mean() for a, b in zip(frames[:-1], frames[1:], strict=True)]
    quarter = np.abs(frames[0].astype(int) - frames[2]).mean()  # +30 degrees against 0
    assert min(step) > 0.5 and quarter > max(step), f"steps {step}, quarter turn {quarter:.2f}"
    # one period: frame 7 is at -45 degrees of phase, as close to frame 0 as frame 1 is (+45 degrees)
    assert abs(np.abs(frames[7].astype(int) - frames[0]).mean() - step[0]) < 0.5 * step[0]


@pytest.mark.gl
def test_a_loop_at_scale_runs_the_scene_at_those_sizes(runtime, gl, tmp_path, monkeypatch):
    """``animations --gpu`` records a flagship scene with its ``at_scale`` parameters instead of the preview's (here
    the CPU ones, four frames of 16,384 boids spread through their box): the simulation it records is that size. On
    a CPU device the command itself refuses in one line (the loops are a million elements)."""
    import ugpcl.docs as docs
    from ugpcl.registry import get

    scene = get("boids")
    made = []
    original = scene.simulation.__init__

    def spy(self, *args, **kwargs):
        original(self, *args, **kwargs)
        made.append(self.params)

    monkeypatch.setattr(scene.simulation, "__init__", spy)
    anim = Animation(scene.at_scale.loop.shows, frames=4, every=2, start=0)
    path = tmp_path / "boids.webp"
    assert docs.record_animation(runtime, "boids", path, anim, scene.at_scale.cpu, (160, 90)) == 4
    assert [(p.max_object_num, p.start) for p in made] == [(16384, "spread")]
    with Image.open(path) as image:
        assert image.size == (160, 90) and image.n_frames >= 3
    if not runtime.is_gpu:
        assert docs.gpu_animations(["boids"]) == 2
