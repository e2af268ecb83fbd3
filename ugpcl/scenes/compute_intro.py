"""Getting started with compute: the array sample and the texture sample (vol.1 ch.2 sections 2.2 and 2.3;
docs/chapters/02-compute-intro.md).

Array sample (SimpleComputeShader_Array): ``KernelFunction_A`` writes ``local id * int_value`` into a 4-int
buffer with one group of 4 work-items, the host reads it back, ``KernelFunction_B`` adds 1 in place, the host
reads again (book: 0 1 2 3, then 1 2 3 4). Texture sample (SimpleComputeShader_Texture): ``KernelFunction_A``
and ``KernelFunction_B`` fill two 512x512 RGBA8 images with a horizontal and a vertical gradient in 8x8 groups.
``DispatchProbe`` records every work-item's ids to reproduce the chapter's SV_DispatchThreadID examples.

Differences from the book: the texture kernels guard x < width, y < height and the global size is rounded up
to whole groups (the book needs sizes that are multiples of 8); devices without images write a uchar4 buffer.
Texture arrays keep row 0 at the bottom, as GL and Unity textures do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl as cl

from ..resources import Allocation
from ..scene import Animation, Scene, param
from ..scene import Params as BaseParams
from ..scene import Simulation as BaseSimulation

ARRAY_LEN = 4
"""Elements of intBuffer = numthreads.x of the array kernels (book: new ComputeBuffer(4, sizeof(int)))."""
PROBE_FIELDS = 10
"""Ints per work-item written by DispatchProbe: group xyz, local xyz, global xyz, SV_GroupIndex."""
IMAGE_FORMAT = cl.ImageFormat(cl.channel_order.RGBA, cl.channel_type.UNORM_INT8)
"""RenderTextureFormat.ARGB32: four 8-bit UNORM channels."""


@dataclass(frozen=True)
class Params(BaseParams):
    sample: str = param("all", choices=("all", "array", "texture"), live=True)
    """Which of the chapter's samples step() runs."""
    int_value: int = param(1, -(1 << 20), 1 << 20, live=True, ignored_when={"sample": "texture"})
    """Multiplier of KernelFunction_A in the array sample (book: intValue)."""
    groups: int = param(1, 1, 64, live=True, ignored_when={"sample": "texture"})
    """Groups launched for the array kernels; > 1 shows the local-id race of KernelFunction_B."""
    tex_width: int = param(512, 1, 16384, ignored_when={"sample": "array"})
    """Texture width, texels (book: new RenderTexture(512, 512, ...))."""
    tex_height: int = param(512, 1, 16384, ignored_when={"sample": "array"})
    """Texture height, texels."""
    local_size: tuple[int, int] = param((8, 8), 1, 1024)
    """numthreads (x, y) of the texture kernels (book: [numthreads(8, 8, 1)])."""
    use_images: str = param("auto", choices=("auto", "image", "buffer"))
    """image2d_t when the device has images ("auto"), or force one path."""
    probe_numthreads: tuple[int, int, int] = param((4, 1, 1), 1, 1024, ignored_when={"sample": "array"})
    """numthreads of the DispatchProbe launch (book's worked example: (4, 1, 1))."""
    probe_groups: tuple[int, int, int] = param((2, 2, 1), 1, 1024, ignored_when={"sample": "array"})
    """Dispatch(x, y, z) group counts of the DispatchProbe launch (book's worked example: (2, 2, 1))."""


class Simulation(BaseSimulation):
    """Both samples of the chapter; each step re-dispatches them as the book's Update does."""

    Params = Params

    @classmethod
    def allocations(cls, params: Params) -> list[Allocation]:
        size = params.tex_width * params.tex_height * 4  # RGBA8
        return [Allocation("texture", size, "tex_width", image=(params.tex_width, params.tex_height))]

    def _reset(self) -> None:
        p, rt = self.params, self.runtime
        if p.local_size[0] * p.local_size[1] > rt.device.max_work_group_size:
            raise ValueError(
                f"local_size must have x*y <= {rt.device.max_work_group_size} on {rt.label}, got {p.local_size}"
            )
        if p.use_images == "image" and not rt.image_support:
            raise ValueError(f"use_images=image, but {rt.label} has no image support; use auto or buffer")
        self.use_images = p.use_images == "image" or (p.use_images == "auto" and rt.image_support)
        self.array_program = rt.program("compute_intro", SAMPLE="SAMPLE_ARRAY")
        self.texture_program = self._texture_program(p.local_size)
        self.int_buffer = rt.zeros(ARRAY_LEN, np.int32)  # book: intComputeBuffer
        self.texture_a = self._texture()
        self.texture_b = self._texture()
        # The book's Start(): the array sample runs once; textures stay blank until the first Update (step).
        self.results: dict[str, np.ndarray] = {}
        if p.sample in ("all", "array"):
            self.run_array_sample()
        if p.sample in ("all", "texture"):
            self.results.update(self.dispatch_probe())
            self.results["tex_a"] = self.read_texture(self.texture_a)
            self.results["tex_b"] = self.read_texture(self.texture_b)

    def _texture_program(self, local_size):
        return self.runtime.program(
            "compute_intro", SAMPLE="SAMPLE_TEXTURE", TX=local_size[0], TY=local_size[1], USE_IMAGES=self.use_images
        )

    def _texture(self):
        """A blank (all zero) texture of tex_width x tex_height."""
        p = self.params
        if not self.use_images:
            return self.runtime.zeros((p.tex_height, p.tex_width, 4), np.uint8)
        image = cl.create_image(
            self.runtime.context, cl.mem_flags.READ_WRITE, IMAGE_FORMAT, shape=(p.tex_width, p.tex_height)
        )
        zero = np.zeros(4, np.float32)
        cl.enqueue_fill_image(self.runtime.queue, image, zero, origin=(0, 0), region=(p.tex_width, p.tex_height))
        return image

    def _texture_args(self, texture) -> tuple:
        if self.use_images:
            return (texture,)
        return (texture.data, np.int32(self.params.tex_width), np.int32(self.params.tex_height))

    def read_texture(self, texture) -> np.ndarray:
        """(H, W, 4) uint8, row 0 = bottom (y = 0), as GL expects it."""
        p = self.params
        if not self.use_images:
            return texture.get()
        out = np.empty((p.tex_height, p.tex_width, 4), np.uint8)
        cl.enqueue_copy(self.runtime.queue, out, texture, origin=(0, 0), region=(p.tex_width, p.tex_height))
        return out

    # {{{ array sample

    def kernel_function_a_array(self) -> np.ndarray:
        """Dispatch KernelFunction_A with `groups` groups of 4, then GetData."""
        self.array_program.kernel("KernelFunction_A")(
            (4 * self.params.groups,), (4,), self.int_buffer.data, np.int32(self.params.int_value)
        )
        return self.int_buffer.get()

    def kernel_function_b_array(self, atomic: bool = False) -> np.ndarray:
        """Dispatch KernelFunction_B (or its atomic_add twin) on the same buffer, then GetData."""
        name = "KernelFunction_B_atomic" if atomic else "KernelFunction_B"
        self.array_program.kernel(name)((4 * self.params.groups,), (4,), self.int_buffer.data)
        return self.int_buffer.get()

    def run_array_sample(self) -> None:
        self.results["array_after_a"] = self.kernel_function_a_array()
        self.results["array_after_b"] = self.kernel_function_b_array()
        self.kernel_function_a_array()
        self.results["array_after_b_atomic"] = self.kernel_function_b_array(atomic=True)

    # }}}

    # {{{ texture sample

    def _dispatch_texture(self, name: str, texture) -> None:
        """One work-item per texel in groups of local_size (the kernel's numthreads), padded to whole groups."""
        p = self.params
        kernel = self.texture_program.kernel(name)
        kernel.over((p.tex_width, p.tex_height), p.local_size, *self._texture_args(texture))

    def kernel_function_a_texture(self) -> None:
        """KernelFunction_A on texture A: horizontal black-to-white gradient."""
        self._dispatch_texture("KernelFunction_A", self.texture_a)

    def kernel_function_b_texture(self) -> None:
        """KernelFunction_B on texture B: vertical gradient, black at the bottom."""
        self._dispatch_texture("KernelFunction_B", self.texture_b)

    def kernel_function_a_1d(self) -> np.ndarray:
        """KernelFunction_A_1D into a fresh texture: the same gradient from a 1-D launch."""
        p = self.params
        texture = self._texture()
        count = p.tex_width * p.tex_height
        self.texture_program.kernel("KernelFunction_A_1D").over(count, 64, *self._texture_args(texture))
        return self.read_texture(texture)

    def kernel_work_group_size(self, name: str = "KernelFunction_A") -> tuple[int, int, int]:
        """GetKernelThreadGroupSizes: the numthreads the texture kernel was compiled with."""
        info = cl.kernel_work_group_info.COMPILE_WORK_GROUP_SIZE
        return tuple(
            int(v) for v in self.texture_program.kernel(name).cl.get_work_group_info(info, self.runtime.device)
        )

    def run_texture_sample(self) -> None:
        self.kernel_function_a_texture()
        self.kernel_function_b_texture()
        self.results["tex_a"] = self.read_texture(self.texture_a)
        self.results["tex_b"] = self.read_texture(self.texture_b)

    # }}}

    # {{{ dispatch probe

    def dispatch_probe(self, numthreads=None, groups=None) -> dict[str, np.ndarray]:
        """Launch DispatchProbe as Dispatch(groups) of [numthreads(numthreads)]; return each work-item's ids."""
        numthreads = tuple(numthreads or self.params.probe_numthreads)
        groups = tuple(groups or self.params.probe_groups)
        global_size = tuple(g * t for g, t in zip(groups, numthreads, strict=True))
        count = int(np.prod(global_size))
        probe = self.runtime.zeros(count * PROBE_FIELDS, np.int32)
        self.texture_program.kernel("DispatchProbe")(global_size, numthreads, probe.data)
        ids = probe.get().reshape(count, PROBE_FIELDS)
        return {
            "probe_group": ids[:, 0:3].copy(),
            "probe_local": ids[:, 3:6].copy(),
            "probe_global": ids[:, 6:9].copy(),
            "probe_flat": ids[:, 9].copy(),
        }

    # }}}

    def _step(self, dt: float) -> None:
        """The book's Update: dispatch the texture kernels; the array sample re-runs so that changed
        int_value/groups show at once (its result is otherwise the same as at Start)."""
        sample = self.params.sample
        if sample in ("all", "array"):
            self.run_array_sample()
        if sample in ("all", "texture"):
            self.run_texture_sample()

    def state(self) -> dict[str, np.ndarray]:
        return {**self.results, "local_size": np.array([*self.params.local_size, 1], np.int32)}

    def stats(self) -> dict:
        return {**super().stats(), "images": self.use_images, "groups": self.params.groups}


SCENES = [
    Scene(
        "compute_intro",
        Simulation,
        "Compute intro: both samples and the dispatch probe (vol.1 ch.2)",
        preview={"steps": 1},
    ),
    Scene(
        "compute_intro_array",
        Simulation,
        "Compute intro sample 1: KernelFunction_A/B on a 4-int buffer",
        {"sample": "array"},
        view="ArrayView",
        preview={"steps": 1},
    ),
    Scene(
        "compute_intro_texture",
        Simulation,
        "Compute intro sample 2: gradients written to two 512x512 textures",
        {"sample": "texture"},
        preview={"steps": 1},
        animation=Animation(
            "the two textures that `KernelFunction_A` and `KernelFunction_B` fill do not change, so the camera swings "
            "round them",
            swing=35.0,
        ),
    ),
]
