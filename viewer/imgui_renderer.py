"""Dear ImGui drawn with moderngl in the viewer's window (the panel of ``viewer.app``)."""

from __future__ import annotations

import ctypes

import moderngl
import numpy as np
from imgui_bundle import imgui
from moderngl_window.integrations.imgui_bundle import ModernglWindowRenderer


class ImguiRenderer(ModernglWindowRenderer):
    """moderngl-window 3.1's Dear ImGui renderer brought to ImGui 1.92 (imgui-bundle 1.92+): there the backend
    creates and updates the textures ImGui asks for (the font atlas grows as glyphs and sizes are used) instead of
    uploading one atlas at start, and each draw command names its texture by ``tex_ref``."""

    def __init__(self, window):
        super().__init__(window)
        imgui.get_io().backend_flags |= imgui.BackendFlags_.renderer_has_textures
        platform = imgui.get_platform_io()
        largest = self.ctx.info["GL_MAX_TEXTURE_SIZE"]
        platform.renderer_texture_max_width = platform.renderer_texture_max_height = largest

    # Mouse input through ImGui's event queue, not its current-state fields as moderngl-window sets them: a press
    # and release inside one slow frame (a click at 5 fps on a CPU) still reach the button.

    def _button(self, button: int) -> int:
        return {self.wnd.mouse.left: 0, self.wnd.mouse.right: 1, self.wnd.mouse.middle: 2}.get(button, 0)

    def mouse_position_event(self, x, y, dx, dy) -> None:
        self.io.add_mouse_pos_event(*self._mouse_pos_viewport(x, y))

    mouse_drag_event = mouse_position_event

    def mouse_press_event(self, x, y, button) -> None:
        self.io.add_mouse_pos_event(*self._mouse_pos_viewport(x, y))
        self.io.add_mouse_button_event(self._button(button), True)

    def mouse_release_event(self, x, y, button) -> None:
        self.io.add_mouse_pos_event(*self._mouse_pos_viewport(x, y))
        self.io.add_mouse_button_event(self._button(button), False)

    def mouse_scroll_event(self, x_offset, y_offset) -> None:
        self.io.add_mouse_wheel_event(x_offset, y_offset)

    def refresh_font_texture(self) -> None:
        """Nothing at start: the atlas arrives through ``update_textures``."""

    def update_textures(self) -> None:
        for tex in imgui.get_platform_io().textures:
            if tex.status == imgui.ImTextureStatus.want_create:
                texture = self.ctx.texture((tex.width, tex.height), 4, tex.get_pixels_array().tobytes())
                self.register_texture(texture)
                tex.set_tex_id(texture.glo)
                tex.status = imgui.ImTextureStatus.ok
            elif tex.status == imgui.ImTextureStatus.want_updates:
                pixels = tex.get_pixels_array().reshape(tex.height, tex.width, 4)
                for r in tex.updates:
                    block = np.ascontiguousarray(pixels[r.y : r.y + r.h, r.x : r.x + r.w])
                    self._textures[tex.tex_id].write(block.tobytes(), viewport=(r.x, r.y, r.w, r.h))
                tex.status = imgui.ImTextureStatus.ok
            elif tex.status == imgui.ImTextureStatus.want_destroy:
                self._textures.pop(tex.tex_id).release()
                tex.set_tex_id(0)
                tex.status = imgui.ImTextureStatus.destroyed

    def render(self, draw_data) -> None:
        self.update_textures()
        width, height = self.io.display_size
        fb_width = int(width * self.io.display_framebuffer_scale[0])
        fb_height = int(height * self.io.display_framebuffer_scale[1])
        if fb_width == 0 or fb_height == 0:
            return
        self.projMat.value = (2.0 / width, 0, 0, 0, 0, -2.0 / height, 0, 0, 0, 0, -1.0, 0, -1.0, 1.0, 0, 1.0)
        draw_data.scale_clip_rects(imgui.ImVec2(*self.io.display_framebuffer_scale))
        self.ctx.enable_only(moderngl.BLEND)
        self.ctx.blend_equation = moderngl.FUNC_ADD
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        for commands in draw_data.cmd_lists:
            for buffer, data, item in (
                (self._vertex_buffer, commands.vtx_buffer, imgui.VERTEX_SIZE),
                (self._index_buffer, commands.idx_buffer, imgui.INDEX_SIZE),
            ):
                if buffer.size < data.size() * item:  # a long panel outgrows the 64k vertices reserved
                    buffer.orphan(data.size() * item)
                buffer.write((ctypes.c_byte * (data.size() * item)).from_address(data.data_address()))
            for command in commands.cmd_buffer:
                self._textures[command.get_tex_id()].use(0)
                x, y, z, w = command.clip_rect
                self.ctx.scissor = int(x), int(fb_height - w), int(z - x), int(w - y)
                self._vao.render(moderngl.TRIANGLES, vertices=command.elem_count, first=command.idx_offset)
        self.ctx.scissor = None
        self.ctx.disable(moderngl.BLEND)
