"""Projection spray view (vol.1 ch.10): every drawable drawn with its canvas (and the guide overlaid, the sample's
CanvasObjectVisualizer), the spray's frustum as lines. A left drag on an object aims the spray at the point under the
mouse and paints while the button is held (the sample's DrawingManager); a drag beside the objects orbits."""

from __future__ import annotations

import math

import moderngl
import numpy as np

from ..camera import OrbitCamera
from ..gl import Lines, load_program, set_camera, set_uniform
from . import Key
from . import View as BaseView

CAMERAS = {
    # the sample's main camera: (0, 7, -10), Euler (40, 0, 0), FOV 60
    "cube_sphere": dict(
        target=(0.0, 0.0, 7.0 / math.tan(math.radians(40)) - 10.0),
        distance=7.0 / math.sin(math.radians(40)),
        pitch=40.0,
    ),
    "stencil": dict(target=(0.0, 0.0, -1.8), distance=6.5, yaw=-48.0, pitch=22.0),
    "figure": dict(target=(0.0, 0.95, 0.0), distance=2.5, yaw=-25.0, pitch=8.0),
}
PICTURE_CAMERAS = {
    # pulled back and turned: the whole 10-unit cube and the spray 8 units above it (the sample's camera cuts
    # the cube's bottom and the spray off)
    "cube_sphere": dict(target=(0.5, -2.0, 0.5), distance=27.0, yaw=-20.0, pitch=25.0),
    # from the spray's side: the figure and the spray's frustum both in the frame
    "figure": dict(target=(0.0, 1.0, -1.1), distance=2.3, yaw=-55.0, pitch=10.0),
}
"""Cameras of pictures and videos (``png_camera``) where the window's would cut the scene at the frame's edge."""
BACKGROUNDS = {"cube_sphere": (1.0, 1.0, 1.0)}
"""The sample's main camera clears to white; the other presets keep the suite's background."""
FRUSTUM_LENGTH = 1.5
"""Length of the spray's frustum lines, units."""


def ray_hit(origin: np.ndarray, direction: np.ndarray, triangles: np.ndarray) -> float | None:
    """Distance along ``direction`` to the nearest of ``triangles`` (F, 3, 3) (both faces), None when none is hit."""
    a, e1, e2 = triangles[:, 0], triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    pv = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = origin - a
    u = np.einsum("ij,ij->i", tv, pv) * inv
    qv = np.cross(tv, e1)
    v = (qv @ direction) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return float(t[hit].min()) if hit.any() else None


class View(BaseView):
    title = "Projection spray (vol.1 ch.10)"
    keys = (
        Key("tab", "aim: orbit (paints by itself) / mouse (left drag on an object sprays)", "next_aim"),
        Key("p", "painting on/off (off: only the guide shows the footprint)", "toggle_painting"),
        Key("c", "clear the canvases", "clear"),
        Key("g", "guide overlay on/off", "toggle_guide"),
        Key("+", "spray angle + 5 degrees", "wider"),
        Key("-", "spray angle - 5 degrees", "narrower"),
        Key("]", "spray range x 1.25", "farther"),
        Key("[", "spray range x 0.8", "nearer"),
        Key("e", "emission x 2", "more_emission"),
        Key("q", "emission / 2", "less_emission"),
        Key("u", "hue cycling / fixed colour", "toggle_hue"),
        Key("l", "headlight shading / the sample's unlit look", "toggle_shading"),
        Key("f", "spray frustum lines on/off", "toggle_frustum"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "projection_spray")
        self.frustum = Lines(ctx)
        self.show_guide, self.show_frustum, self.shade = True, True, 1.0
        self.background = BACKGROUNDS.get(sim.params.preset, BaseView.background)
        self.objects: list = []
        self.uploaded: list[dict] = []  # per drawable: the sim's version of each texture last written

    def make_camera(self):
        return OrbitCamera(**CAMERAS[self.sim.params.preset])

    def png_camera(self):
        preset = self.sim.params.preset
        return OrbitCamera(**PICTURE_CAMERAS[preset]) if preset in PICTURE_CAMERAS else self.make_camera()

    def _build(self) -> None:
        """Vertex arrays and 8-bit textures per drawable (again after a reset replaced them)."""
        for vao, vbo, canvas, guide in self.objects:
            for obj in (vao, vbo, canvas, guide):
                obj.release()
        self.objects = []
        tex = self.sim.params.tex
        for d in self.sim.drawables:
            m = d.mesh
            data = np.hstack([m.vertices, m.normals, m.uvs]).astype("f4")[m.faces.ravel()]
            vbo = self.ctx.buffer(data.tobytes())
            vao = self.ctx.vertex_array(self.program, [(vbo, "3f 3f 2f", "in_position", "in_normal", "in_uv")])
            textures = []
            for _ in range(2):  # 8-bit colour, as the sim hands it (texture_rgba8): what the screen shows
                texture = self.ctx.texture((tex, tex), 4, dtype="f1")
                texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
                texture.repeat_x = texture.repeat_y = False
                textures.append(texture)
            self.objects.append((vao, vbo, *textures))
        self.built_for = self.sim.textures
        self.uploaded = [{} for _ in self.objects]

    def upload(self) -> None:
        if not self.objects or self.built_for is not self.sim.textures:
            self._build()
        for k, (_, _, canvas, guide) in enumerate(self.objects):
            for name, texture in (("canvas", canvas), ("guide_canvas", guide)):
                version = self.sim.changed[k][name]
                if self.uploaded[k].get(name) != version:  # only what changed: the guide stays while painting
                    texture.write(self.sim.texture_rgba8(k, name))
                    self.uploaded[k][name] = version
        self.frustum.set(self.frustum_lines())
        self.frustum.color = (*self.sim.color(self.sim.time)[:3], 1.0)

    def frustum_lines(self) -> np.ndarray:
        """The spray's pyramid (apex and 4 edges, FRUSTUM_LENGTH long) and a line to its aim point."""
        pose, aim = self.sim.spray_pose(self.sim.time)
        origin = pose[:3, 3]
        half = math.tan(math.radians(self.sim.params.spray_angle) / 2)
        corners = [
            origin + FRUSTUM_LENGTH * (pose[:3, 2] + sx * half * pose[:3, 0] + sy * half * pose[:3, 1])
            for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))
        ]
        lines = [origin, aim]
        for i in range(4):
            lines += [origin, corners[i], corners[i], corners[(i + 1) % 4]]
        return np.array(lines)

    def draw(self, camera) -> None:
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.disable(moderngl.CULL_FACE)  # the plate and the wall are single-sided quads seen from both sides
        set_camera(self.program, camera)
        set_uniform(self.program, "show_guide", self.show_guide)
        set_uniform(self.program, "shade", self.shade)
        self.program["canvas"].value, self.program["guide"].value = 0, 1
        for (vao, _, canvas, guide), o2w in zip(self.objects, self.sim.object_to_world(self.sim.time), strict=True):
            set_uniform(self.program, "m_model", o2w)
            canvas.use(0)
            guide.use(1)
            vao.render(moderngl.TRIANGLES)
        if self.show_frustum:
            self.frustum.draw(camera)

    def status(self) -> list[str]:
        p = self.sim.params
        mode = "painting" if p.painting else "guide only"
        return [f"{p.preset}  aim {p.aim}  {mode}  angle {p.spray_angle:g}  range {p.spray_range:g}"]

    # {{{ mouse

    def pick(self, camera, u: float, v: float) -> np.ndarray | None:
        """The point of a drawable under window position (u, v), in the scene's (Unity) coordinates."""
        inverse = np.linalg.inv(camera.projection() @ camera.view())
        near, far = (inverse @ np.array([2 * u - 1, 2 * v - 1, z, 1.0]) for z in (-1.0, 1.0))
        near, far = near[:3] / near[3], far[:3] / far[3]
        direction = far - near
        o2w = self.sim.object_to_world(self.sim.time)
        triangles = np.concatenate([t @ m[:3, :3].T + m[:3, 3] for t, m in zip(self.sim.triangles, o2w, strict=True)])
        t = ray_hit(near, direction, triangles)
        return None if t is None else near + t * direction

    def on_drag(self, camera, u: float, v: float, du: float, dv: float) -> None:
        point = self.pick(camera, u, v)
        if point is None:
            camera.drag(du * 600, dv * 600)
            return
        self.sim.aim_at(point)
        self.sim.update(aim="mouse", painting=True)

    def on_release(self, camera) -> None:
        if self.sim.params.aim == "mouse":
            self.sim.update(painting=False)

    # }}}

    # {{{ key actions

    def next_aim(self) -> None:
        self.sim.update(aim="mouse" if self.sim.params.aim == "orbit" else "orbit")
        self.sim.update(painting=self.sim.params.aim == "orbit")

    def toggle_painting(self) -> None:
        self.sim.update(painting=not self.sim.params.painting)

    def clear(self) -> None:
        self.sim.clear()

    def toggle_guide(self) -> None:
        self.show_guide = not self.show_guide

    def wider(self) -> None:
        self.sim.update(spray_angle=min(170.0, self.sim.params.spray_angle + 5.0))

    def narrower(self) -> None:
        self.sim.update(spray_angle=max(5.0, self.sim.params.spray_angle - 5.0))

    def farther(self) -> None:
        self.sim.update(spray_range=min(1e4, self.sim.params.spray_range * 1.25))

    def nearer(self) -> None:
        self.sim.update(spray_range=max(0.02, self.sim.params.spray_range * 0.8))

    def more_emission(self) -> None:
        self.sim.update(emission=min(1e4, self.sim.params.emission * 2.0))

    def less_emission(self) -> None:
        self.sim.update(emission=self.sim.params.emission / 2.0)

    def toggle_hue(self) -> None:
        self.sim.update(hue_cycle=not self.sim.params.hue_cycle)

    def toggle_shading(self) -> None:
        self.shade = 0.0 if self.shade else 1.0

    def toggle_frustum(self) -> None:
        self.show_frustum = not self.show_frustum

    # }}}
