"""Procedural modeling views (vol.1 ch.1): the generated meshes lit, or in the book's UV and Normal debug materials.

With ``material=all`` a mesh is drawn three times, Standard, UV and Normal from left to right, as the book's scenes
do (figure 1.2). The meshes keep Unity's coordinates and index order; the camera mirrors z, so Unity's front faces
turn clockwise on screen and are culled as Unity culls them (Cull Back).
"""

from __future__ import annotations

import moderngl
import numpy as np

from ugpcl.geometry.mesh import Mesh
from ugpcl.scenes.procedural_modeling import CURVES, MATERIALS, MAX_GRID

from ..camera import OrbitCamera, OrthoCamera
from ..gl import GrowableBuffer, Lines, load_program, set_camera, set_uniform
from ..meshes import uv_sphere
from . import Key
from . import View as BaseView

MATERIAL_CODES = {"standard": 0, "uv": 1, "normal": 2}
"""The fragment shader's ``material`` uniform."""
FRAME_COLORS = {"tangent": (1.0, 0.0, 0.0, 1.0), "normal": (0.0, 1.0, 0.0, 1.0), "binormal": (0.0, 0.4, 1.0, 1.0)}
"""The overlay's frame arrows: T red, N green, B blue."""
NO_CLIP = 2.0
"""grow_t of meshes that do not grow: above every uv.y."""
TREE_FILL = 0.85
"""The tree's PNG camera: the grown tree(s) reach this share of the picture's half-width or half-height."""
TUBE_FILL = 0.94
"""The tube's PNG camera: the row of copies reaches this share of the picture's half-width or half-height."""


def translation(offset) -> np.ndarray:
    m = np.identity(4)
    m[:3, 3] = offset
    return m


def camera_at(eye, pitch: float, fov: float = 60.0) -> OrbitCamera:
    """A camera at ``eye`` looking along +z pitched down by ``pitch`` degrees (the book's scene cameras), orbiting
    the point where its view ray crosses z = 0."""
    distance = -eye[2] / np.cos(np.radians(pitch))
    target = (eye[0], eye[1] - distance * np.sin(np.radians(pitch)), 0.0)
    return OrbitCamera(target=target, distance=float(distance), pitch=pitch, fov=fov)


class MeshPart:
    """One mesh in GL buffers (position, normal, uv + indices), re-uploaded only when the mesh object changes."""

    def __init__(self, ctx: moderngl.Context, program: moderngl.Program):
        self.ctx, self.program = ctx, program
        self.vbo, self.ibo = GrowableBuffer(ctx, headroom=1.25), GrowableBuffer(ctx, headroom=1.25)
        self.mesh, self.vao, self.count = None, None, 0

    def set(self, mesh: Mesh) -> None:
        if mesh is self.mesh:
            return
        self.mesh = mesh
        n = len(mesh.vertices)
        normals = mesh.normals if mesh.normals is not None else np.zeros((n, 3), np.float32)
        uvs = mesh.uvs if mesh.uvs is not None else np.zeros((n, 2), np.float32)
        grown = self.vbo.write(np.concatenate([mesh.vertices, normals, uvs], axis=1).astype(np.float32))
        grown |= self.ibo.write(mesh.faces.astype(np.int32))
        if grown or self.vao is None:
            self.vao = self.ctx.vertex_array(
                self.program,
                [(self.vbo.buffer, "3f 3f 2f", "in_position", "in_normal", "in_uv")],
                index_buffer=self.ibo.buffer,
                index_element_size=4,
            )
        self.count = 3 * len(mesh.faces)

    def draw(self, model: np.ndarray, material: str, grow_t: float = NO_CLIP, albedo=(1.0, 1.0, 1.0)) -> None:
        if not self.count:
            return
        set_uniform(self.program, "m_model", model)
        set_uniform(self.program, "material", MATERIAL_CODES[material])
        set_uniform(self.program, "grow_t", float(grow_t))
        set_uniform(self.program, "albedo", tuple(albedo))
        self.vao.render(moderngl.TRIANGLES, vertices=self.count)


class MeshView(BaseView):
    """The sim's mesh in its material(s); subclasses add their scene's camera, keys and extra parts."""

    spacing = 2.5
    """x distance between the Standard, UV and Normal copies (the book's scenes: -2.5, 0, 2.5)."""
    shared_keys = (
        Key("m", "material: standard / uv / normal / all three", "next_material"),
        Key("w", "wireframe on/off", "toggle_wireframe"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.program = load_program(ctx, "procedural_modeling")
        self.part = MeshPart(ctx, self.program)
        self.wireframe = False
        self.front_face = "cw"  # Unity's front faces behind the camera's z mirror

    def layout(self) -> list[tuple[tuple[float, float, float], str]]:
        """(offset, material) of each copy of the mesh."""
        material = self.sim.params.material
        if material == "all":
            return [
                ((-self.spacing, 0.0, 0.0), "standard"),
                ((0.0, 0.0, 0.0), "uv"),
                ((self.spacing, 0.0, 0.0), "normal"),
            ]
        return [((0.0, 0.0, 0.0), material)]

    def laid_out_vertices(self) -> list[np.ndarray]:
        """The mesh's vertices at each copy of ``layout()`` (what a picture's camera frames)."""
        vertices = self.sim.mesh().vertices.astype(np.float64)
        return [vertices + offset for offset, _ in self.layout()]

    def grow_t(self) -> float:
        return NO_CLIP

    def upload(self) -> None:
        self.part.set(self.sim.mesh())

    def draw(self, camera) -> None:
        ctx = self.ctx
        ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.front_face = self.front_face
        ctx.wireframe = self.wireframe
        set_camera(self.program, camera)
        for offset, material in self.layout():
            self.part.draw(translation(offset), material, self.grow_t())
        self.draw_extras(camera)
        ctx.wireframe = False
        ctx.front_face = "ccw"
        ctx.disable(moderngl.CULL_FACE)

    def draw_extras(self, camera) -> None:
        """Whatever a scene draws beside its mesh."""

    def status(self) -> list[str]:
        s = self.sim.stats()
        return [f"{s['vertices']} vertices, {s['triangles']} triangles  material: {self.sim.params.material}"]

    # {{{ key actions

    def next_material(self) -> None:
        self.sim.update(material=MATERIALS[(MATERIALS.index(self.sim.params.material) + 1) % len(MATERIALS)])

    def toggle_wireframe(self) -> None:
        self.wireframe = not self.wireframe

    def _change(self, name: str, value) -> None:
        """Set a parameter clamped to its declared range (the book's inspector sliders stop at their ends)."""
        meta = next(f.metadata for f in self.sim.params.__dataclass_fields__.values() if f.name == name)
        value = min(max(value, meta["lo"]), meta["hi"])
        self.sim.update(**{name: type(getattr(self.sim.params, name))(round(value, 6))})

    # }}}


class QuadView(MeshView):
    title = "Quad (vol.1 ch.1)"
    keys = (
        *MeshView.shared_keys,
        Key("[", "size - 0.25", "smaller"),
        Key("]", "size + 0.25", "larger"),
    )

    def make_camera(self):
        return camera_at((0.0, 0.0, -5.0), 0.0)  # Quad.unity: (0, 0, -5)

    def smaller(self) -> None:
        self._change("size", self.sim.params.size - 0.25)

    def larger(self) -> None:
        self._change("size", self.sim.params.size + 0.25)


class PlaneView(MeshView):
    title = "Plane and parametric planes (vol.1 ch.1)"
    keys = (
        *MeshView.shared_keys,
        Key("[", "fewer vertices per side (halve above 32)", "fewer_segments"),
        Key("]", "more vertices per side (double from 32)", "more_segments"),
        Key("+", "depth x 1.25", "deeper"),
        Key("-", "depth / 1.25", "shallower"),
        Key("tab", "surface: flat / mountain / terrain", "next_surface"),
        Key("o", "builder: numpy / OpenCL kernels", "toggle_builder"),
    )

    @property
    def background(self):
        # ParametricPlane.unity clears to black; Plane.unity has Unity's blue-grey
        return BaseView.background if self.sim.params.surface == "flat" else (0.0, 0.0, 0.0)

    def make_camera(self):
        if self.sim.params.surface == "flat":
            return camera_at((0.0, 2.0, -4.5), 30.0)
        return camera_at((0.0, 3.0, -5.0), 30.0)  # ParametricPlane.unity: (0, 3, -5), pitched 30 degrees

    def png_camera(self):
        p = self.sim.params
        if p.surface == "flat":
            # steep and close: the book's camera sees the planes edge-on, their uv gradient unreadable; the
            # distance fits the row of copies (a 60-degree field is about 1.5 distances wide at 16:9)
            span = (2 * self.spacing if p.material == "all" else 0.0) + max(p.width, p.height)
            return OrbitCamera(target=(0.0, 0.0, 0.0), distance=0.66 * span, pitch=60.0)
        camera = self.make_camera()
        camera.distance *= 0.55  # the book's shows a small plane
        return camera

    def status(self) -> list[str]:
        p = self.sim.params
        return [*super().status(), f"{p.surface} {p.width_segments} x {p.height_segments}  builder: {p.builder}"]

    def _segments(self, n: int) -> None:
        n = min(max(n, 2), MAX_GRID)
        self.sim.update(width_segments=n, height_segments=n)

    def fewer_segments(self) -> None:
        n = self.sim.params.width_segments
        self._segments(n // 2 if n > 32 else n - 1)

    def more_segments(self) -> None:
        n = self.sim.params.width_segments
        self._segments(n * 2 if n >= 32 else n + 1)

    def deeper(self) -> None:
        self._change("depth", self.sim.params.depth * 1.25)

    def shallower(self) -> None:
        self._change("depth", self.sim.params.depth / 1.25)

    def next_surface(self) -> None:
        surfaces = ("flat", "mountain", "terrain")
        self.sim.update(surface=surfaces[(surfaces.index(self.sim.params.surface) + 1) % 3])

    def toggle_builder(self) -> None:
        self.sim.update(builder="opencl" if self.sim.params.builder == "numpy" else "numpy")


class CylinderView(MeshView):
    title = "Cylinder and BadCylinder (vol.1 ch.1)"
    keys = (
        *MeshView.shared_keys,
        Key("[", "segments - 1", "fewer_segments"),
        Key("]", "segments + 1", "more_segments"),
        Key("+", "radius + 0.1", "wider"),
        Key("-", "radius - 0.1", "narrower"),
        Key("b", "this cylinder: Cylinder / BadCylinder", "toggle_bad"),
        Key("c", "caps on/off (open_ended)", "toggle_caps"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.other = MeshPart(ctx, self.program)

    def make_camera(self):
        return camera_at((-1.25, 2.0, -7.5), 15.0)  # Cylinder.unity's camera, pulled back to show x = -5 too

    def png_camera(self):
        return OrbitCamera(target=(-1.25, 0.0, 0.0), distance=9.0, pitch=32.0)  # higher: the caps show

    def upload(self) -> None:
        super().upload()
        key = (self.sim.params, "other")
        if getattr(self, "_other_key", None) != key:  # the other variant at x = -5, lit (figure 1.9)
            self.other.set(self.sim.mesh_of(not self.sim.params.bad))
            self._other_key = key

    def draw_extras(self, camera) -> None:
        self.other.draw(translation((-2 * self.spacing, 0.0, 0.0)), "standard")

    def fewer_segments(self) -> None:
        self._change("segments", self.sim.params.segments - 1)

    def more_segments(self) -> None:
        self._change("segments", self.sim.params.segments + 1)

    def wider(self) -> None:
        self._change("radius", self.sim.params.radius + 0.1)

    def narrower(self) -> None:
        self._change("radius", self.sim.params.radius - 0.1)

    def toggle_bad(self) -> None:
        self.sim.update(bad=not self.sim.params.bad)

    def toggle_caps(self) -> None:
        self.sim.update(open_ended=not self.sim.params.open_ended)


class TubularView(MeshView):
    title = "Tubular (vol.1 ch.1)"
    spacing = 3.5
    """Wider than the book's 2.5: the scene's curve spans 3 units in x."""
    keys = (
        *MeshView.shared_keys,
        Key("[", "tubular_segments - 1", "fewer_segments"),
        Key("]", "tubular_segments + 1", "more_segments"),
        Key("+", "radius + 0.05", "wider"),
        Key("-", "radius - 0.05", "narrower"),
        Key("f", "frames (T red, N green, B blue) and division points on/off", "toggle_frames"),
        Key("c", "closed on/off", "toggle_closed"),
        Key("tab", "curve: scene / script / knot", "next_curve"),
        Key("v", "closed frames: fixed / book", "toggle_variant"),
    )
    frame_scale = 0.3
    """Length of the frame arrows."""
    point_radius = 0.04
    """Radius of the division-point spheres (figure 1.12)."""

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.show_frames = True
        self.arrows = {name: Lines(ctx, color=color) for name, color in FRAME_COLORS.items()}
        vertices, indices = uv_sphere(16, 8)
        sphere = Mesh(vertices[:, :3], indices.reshape(-1, 3), vertices[:, 3:], np.zeros((len(vertices), 2)))
        self.sphere = MeshPart(ctx, self.program)
        self.sphere.set(sphere)
        self._overlay_of = None

    def make_camera(self):
        return camera_at((0.5, 2.0, -6.5), 15.0)  # Tubular.unity: (0, 2, -5) pitched 15, pulled back

    def png_camera(self):
        """The start camera's angle, as close as keeps every copy of the tube in the picture: the three copies
        side by side make a wide, low row, which the window's camera shows small (the frame arrows, which reach
        past a thin tube, count too)."""
        camera = self.make_camera()
        state = self.sim.state()
        arrows = [state["curve_points"] + self.frame_scale * state[key] for key in ("frame_t", "frame_n", "frame_b")]
        points = self.laid_out_vertices() + [a + self.layout()[0][0] for a in arrows]
        camera.fit(np.concatenate(points), TUBE_FILL)
        return camera

    def upload(self) -> None:
        super().upload()
        if self._overlay_of is self.sim.mesh():
            return
        self._overlay_of = self.sim.mesh()
        state = self.sim.state()
        centers = state["curve_points"][:, None]
        for name, key in (("tangent", "frame_t"), ("normal", "frame_n"), ("binormal", "frame_b")):
            ends = centers + self.frame_scale * state[key][:, None]
            segments = np.concatenate([np.broadcast_to(centers, ends.shape), ends], axis=1)
            self.arrows[name].set((segments + self.layout()[0][0]).reshape(-1, 3))  # on the first copy only
        self.points = state["curve_points"]

    def draw_extras(self, camera) -> None:
        if not self.show_frames:
            return
        self.ctx.disable(moderngl.DEPTH_TEST)  # the curve and its frames lie inside the tube: draw them over it
        scale = np.diag([self.point_radius] * 3 + [1.0])
        offset = self.layout()[0][0]
        for point in self.points:
            self.sphere.draw(translation(np.add(offset, point)) @ scale, "standard", albedo=(1.0, 0.85, 0.2))
        for lines in self.arrows.values():
            lines.draw(camera)
        self.ctx.enable(moderngl.DEPTH_TEST)

    def fewer_segments(self) -> None:
        self._change("tubular_segments", self.sim.params.tubular_segments - 1)

    def more_segments(self) -> None:
        self._change("tubular_segments", self.sim.params.tubular_segments + 1)

    def wider(self) -> None:
        self._change("radius", self.sim.params.radius + 0.05)

    def narrower(self) -> None:
        self._change("radius", self.sim.params.radius - 0.05)

    def toggle_frames(self) -> None:
        self.show_frames = not self.show_frames

    def toggle_closed(self) -> None:
        self.sim.update(closed=not self.sim.params.closed)

    def next_curve(self) -> None:
        names = tuple(CURVES)
        self.sim.update(curve=names[(names.index(self.sim.params.curve) + 1) % len(names)])

    def toggle_variant(self) -> None:
        self.sim.update(variant="book" if self.sim.params.variant == "fixed" else "fixed")


class TreeView(MeshView):
    title = "Procedural tree (vol.1 ch.1)"
    spacing = 3.0
    keys = (
        *MeshView.shared_keys,
        Key("[", "generations - 1", "fewer_generations"),
        Key("]", "generations + 1", "more_generations"),
        Key("+", "growth_angle_scale + 0.5", "wider_angles"),
        Key("-", "growth_angle_scale - 0.5", "narrower_angles"),
        Key("t", "another tree (random_seed + 1)", "next_tree"),
        Key("g", "grow again (_T from 0)", "grow_again"),
        Key("o", "builder: numpy / OpenCL kernels", "toggle_builder"),
    )

    def make_camera(self):
        p = self.sim.params
        side = int(np.ceil(np.sqrt(p.trees)))
        extent = max(side * p.spacing, 3.0 if p.material != "all" else 9.0)
        return OrbitCamera(target=(0.0, 2.0, 0.0), distance=1.1 * extent + 2.0, pitch=10.0 if side == 1 else 30.0)

    def png_camera(self):
        """The start camera's angle, aimed at the middle of the grown tree(s) (every copy of the layout) and as
        close as keeps all of them in the picture: a tree leans its own way, and a forest is wider than tall."""
        camera = self.make_camera()
        points = np.concatenate(self.laid_out_vertices())
        lower, upper = points.min(axis=0), points.max(axis=0)
        camera.target = tuple(float(c) for c in (lower + upper) / 2)
        camera.fit(points, TREE_FILL)
        return camera

    def grow_t(self) -> float:
        return self.sim.grow_t

    def status(self) -> list[str]:
        s = self.sim.stats()
        return [*super().status(), f"{s['trees']} tree(s), {s['branches']} branches  _T = {s['_T']:.2f}"]

    def fewer_generations(self) -> None:
        self._change("generations", self.sim.params.generations - 1)

    def more_generations(self) -> None:
        self._change("generations", self.sim.params.generations + 1)

    def wider_angles(self) -> None:
        self._change("growth_angle_scale", self.sim.params.growth_angle_scale + 0.5)

    def narrower_angles(self) -> None:
        self._change("growth_angle_scale", self.sim.params.growth_angle_scale - 0.5)

    def next_tree(self) -> None:
        self.sim.update(random_seed=(self.sim.params.random_seed + 1) % 2**31)

    def grow_again(self) -> None:
        self.sim.restart_growth()

    def toggle_builder(self) -> None:
        self.sim.update(builder="opencl" if self.sim.params.builder == "numpy" else "numpy")


class LSystemView(BaseView):
    title = "L-system (vol.1 ch.1)"
    background = (1.0, 1.0, 1.0)
    """LSystem.unity's white background."""
    keys = (
        Key("[", "depth - 1", "shallower"),
        Key("]", "depth + 1", "deeper"),
        Key("+", "angle + 5 degrees", "wider"),
        Key("-", "angle - 5 degrees", "narrower"),
    )

    def __init__(self, ctx: moderngl.Context, sim):
        super().__init__(ctx, sim)
        self.lines = Lines(ctx)

    def make_camera(self):
        # LSystem.unity: orthographic, size 2, at (0, 1.2, -5)
        return OrthoCamera(target=(0.0, 1.2, 0.0), distance=5.0, half_height=2.0)

    def upload(self) -> None:
        self.lines.set(self.sim.state()["segments"].reshape(-1, 3))
        self.lines.color = (*self.sim.params.color, 1.0)

    def draw(self, camera) -> None:
        self.lines.draw(camera)

    def status(self) -> list[str]:
        p = self.sim.params
        return [f"depth {p.depth}: {2**p.depth - 1} lines  angle {p.angle:g}"]

    def _change(self, name: str, value) -> None:
        MeshView._change(self, name, value)

    def shallower(self) -> None:
        self._change("depth", self.sim.params.depth - 1)

    def deeper(self) -> None:
        self._change("depth", self.sim.params.depth + 1)

    def wider(self) -> None:
        self._change("angle", self.sim.params.angle + 5.0)

    def narrower(self) -> None:
        self._change("angle", self.sim.params.angle - 5.0)
