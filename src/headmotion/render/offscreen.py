"""Offscreen rendering of the head model with OpenGL (moderngl on EGL) — thesis §4.2.3.

The thesis compared three animation styles for subjective tests: *textured* (a human-like head
with skin, hair and ears; judged best), *smooth* (realistic shape, untextured, shaded) and
*silhouette*, always with a black box over the eyes and the mouth so that eye and lip motion do
not take part.  :class:`HeadRenderer` draws :func:`~headmotion.render.mesh.build_head_mesh` in
any of these styles, rotated (and translated) by a head pose, into an RGB image; several poses can
be drawn side by side in a grid with a label on each cell.

The context is created headless with ``moderngl.create_standalone_context(backend="egl")``, which
runs on Mesa's llvmpipe CPU rasteriser when there is no GPU (Debian packages ``libegl1
libgl1-mesa-dri libegl-mesa0``).  moderngl is imported only when a renderer is created.

The camera looks at the speaker's face from the front: +x of the head frame (speaker's left) is
the image's right, +y is up.  The projection is flipped vertically so that ``glReadPixels``
returns rows top to bottom, ready for a video encoder without a copy.

Libraries considered: pyrender/trimesh (a scene graph and its own EGL handling, heavier and not
maintained for EGL on recent Mesa), VTK offscreen (large), Blender (far too heavy per frame);
moderngl is a thin, fast wrapper that the design names.
"""

from __future__ import annotations

import numpy as np

from ..errors import MissingDependencyError, ParameterError
from . import mesh as _mesh

STYLES = ("textured", "smooth", "silhouette")

_BACKGROUND = {
    "textured": (0.80, 0.82, 0.85),
    "smooth": (0.86, 0.86, 0.86),
    "silhouette": (1.0, 1.0, 1.0),
}

_VERTEX_SHADER = """
#version 330
in vec3 in_pos;
in vec3 in_nrm;
in vec3 in_col;
in float in_mat;
in float in_w;
uniform mat4 u_viewproj;
uniform vec3 u_rotvec;        // head rotation (radians, axis * angle)
uniform vec3 u_trans;
out vec3 v_world;
out vec3 v_nrm;
out vec3 v_col;
out vec3 v_obj;
flat out int v_mat;
// Rodrigues' formula; the neck is skinned by scaling the angle (no candy-wrapper collapse)
mat3 axis_angle(vec3 r) {
    float a = length(r);
    if (a < 1e-8) return mat3(1.0);
    vec3 k = r / a;
    mat3 K = mat3(0.0, k.z, -k.y,  -k.z, 0.0, k.x,  k.y, -k.x, 0.0);   // column-major
    return mat3(1.0) + sin(a) * K + (1.0 - cos(a)) * K * K;
}
void main() {
    mat3 R = axis_angle(u_rotvec * in_w);
    vec3 p = R * in_pos + u_trans * in_w;
    v_nrm = normalize(R * in_nrm);
    v_world = p;
    v_obj = in_pos;
    v_col = in_col;
    v_mat = int(in_mat + 0.5);
    gl_Position = u_viewproj * vec4(p, 1.0);
}
"""

_FRAGMENT_SHADER = """
#version 330
in vec3 v_world;
in vec3 v_nrm;
in vec3 v_col;
in vec3 v_obj;
flat in int v_mat;
uniform int u_style;          // 0 textured, 1 smooth, 2 silhouette
uniform vec3 u_eye;
out vec4 f_color;

const int SKIN = 0; const int HAIR = 1; const int CLOTH = 2; const int MASK = 3; const int EAR = 4;

float hash(vec3 p) { return fract(sin(dot(p, vec3(127.1, 311.7, 74.7))) * 43758.5453); }

void main() {
    if (u_style == 2) { f_color = vec4(0.0, 0.0, 0.0, 1.0); return; }
    if (v_mat == MASK) { f_color = vec4(0.0, 0.0, 0.0, 1.0); return; }
    vec3 n = normalize(v_nrm);
    vec3 v = normalize(u_eye - v_world);
    if (dot(n, v) < 0.0) n = -n;
    // lights fixed in the world: key (upper left of the camera), fill (right), rim (behind, above)
    vec3 l1 = normalize(vec3(-0.55, 0.60, 0.75));
    vec3 l2 = normalize(vec3(0.80, 0.10, 0.55));
    vec3 l3 = normalize(vec3(0.20, 0.70, -0.80));
    vec3 base;
    float spec_k; float shin; float wrap;
    if (u_style == 1) {
        base = (v_mat == CLOTH) ? vec3(0.42, 0.43, 0.45) : vec3(0.74, 0.73, 0.72);
        spec_k = 0.18; shin = 30.0; wrap = 0.0;
    } else {
        base = pow(v_col, vec3(2.2));
        spec_k = 0.10; shin = 18.0; wrap = 0.35;
        if (v_mat == HAIR) {
            // strands running from the crown: brightness streaks around the vertical axis
            float az = atan(v_obj.x, v_obj.z - 0.01);
            float el = v_obj.y;
            float s = 0.5 + 0.5 * sin(az * 220.0 + 9.0 * sin(el * 90.0) + 40.0 * hash(floor(vec3(az * 60.0, 0.0, 0.0))));
            base *= 0.78 + 0.40 * s;
            spec_k = 0.22; shin = 40.0; wrap = 0.0;
        } else if (v_mat == CLOTH) {
            spec_k = 0.03; shin = 8.0; wrap = 0.1;
        }
    }
    float d1 = max((dot(n, l1) + wrap) / (1.0 + wrap), 0.0);
    float d2 = max((dot(n, l2) + wrap) / (1.0 + wrap), 0.0);
    float rim = pow(1.0 - max(dot(n, v), 0.0), 3.0) * max(dot(n, l3) + 0.3, 0.0);
    float hemi = 0.5 + 0.5 * n.y;
    vec3 amb = mix(vec3(0.10, 0.09, 0.09), vec3(0.20, 0.21, 0.24), hemi);
    vec3 c = base * (amb + 0.95 * d1 * vec3(1.0, 0.97, 0.93) + 0.35 * d2 * vec3(0.85, 0.90, 1.0));
    if (u_style == 0 && (v_mat == SKIN || v_mat == EAR)) {
        // a touch of red where light wraps round the terminator (cheap subsurface look)
        float sss = max(dot(n, l1) + 0.45, 0.0) * max(0.45 - dot(n, l1), 0.0);
        c += base * vec3(0.35, 0.08, 0.04) * sss;
    }
    vec3 h1 = normalize(l1 + v);
    c += spec_k * pow(max(dot(n, h1), 0.0), shin) * vec3(1.0);
    c += 0.35 * rim * vec3(1.0);
    c = pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2));
    f_color = vec4(c, 1.0);
}
"""

_OVERLAY_VS = """
#version 330
in vec2 in_pos;
out vec2 v_uv;
void main() { v_uv = 0.5 * (in_pos + 1.0); gl_Position = vec4(in_pos, 0.0, 1.0); }
"""

_OVERLAY_FS = """
#version 330
uniform sampler2D u_tex;
in vec2 v_uv;
out vec4 f_color;
void main() { f_color = texture(u_tex, v_uv); }
"""


def _perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    f = 1.0 / np.tan(np.radians(fov_y_deg) / 2)
    m = np.zeros((4, 4))
    m[0, 0] = f / aspect
    m[1, 1] = f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def _look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    eye, target, up = (np.asarray(a, float) for a in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def parse_size(size) -> tuple[int, int]:
    """``"640x480"`` or ``(640, 480)`` → ``(640, 480)``; both must be even (yuv420p needs it)."""
    if isinstance(size, str):
        try:
            w, h = (int(v) for v in size.lower().replace("×", "x").split("x"))
        except ValueError:
            raise ParameterError(f"size must look like WIDTHxHEIGHT, e.g. 640x480; got {size!r}") from None
    else:
        try:
            w, h = (int(v) for v in size)
        except (TypeError, ValueError):
            raise ParameterError(f"size must be (width, height); got {size!r}") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise ParameterError(f"size must be between 16 and 8192 pixels per side; got {w}x{h}")
    if w % 2 or h % 2:
        raise ParameterError(f"width and height must be even for H.264 yuv420p video; got {w}x{h}")
    return w, h


def create_context():
    """A headless OpenGL 3.3 context on EGL (Mesa llvmpipe when there is no GPU)."""
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - moderngl is a dependency
        raise MissingDependencyError(f"rendering needs moderngl ({exc}); pip install moderngl") from exc
    try:
        return moderngl.create_standalone_context(backend="egl", require=330)
    except Exception as exc:
        raise MissingDependencyError(
            "could not create an offscreen OpenGL context with EGL "
            f"({exc}); on Debian install libegl1 libgl1-mesa-dri libegl-mesa0"
        ) from exc


class HeadRenderer:
    """Draw the head in a grid of ``rows × cols`` cells, each ``size`` pixels.

    Parameters
    ----------
    size : (int, int) or "WxH", pixels of one cell (even numbers)
    style : {"textured", "smooth", "silhouette"}
    mask : bool, draw the black boxes over the eyes and mouth (the thesis's choice; default)
    grid : (rows, cols), cells in the image
    labels : list of str or None, one per cell (drawn at the top of each cell)
    samples : int, multisampling (0 = none, the default; 4 = smooth edges, but llvmpipe's
        multisampling costs about 3× the time of a frame)

    Examples
    --------
    >>> r = HeadRenderer(size=(320, 240))
    >>> img = r.render([[0.2, 0.0, 0.0]])           # (240, 320, 3) uint8, a nod down
    """

    def __init__(self, *, size=(640, 480), style: str = "textured", mask: bool = True,
                 grid: tuple[int, int] = (1, 1), labels=None, samples: int = 0):
        if style not in STYLES:
            raise ParameterError(f"style must be one of {', '.join(STYLES)}; got {style!r}")
        self.cell = parse_size(size)
        self.style = style
        self.mask = bool(mask)
        rows, cols = (int(v) for v in grid)
        if rows < 1 or cols < 1:
            raise ParameterError(f"grid must have at least one row and one column; got {grid!r}")
        self.grid = (rows, cols)
        self.width, self.height = self.cell[0] * cols, self.cell[1] * rows
        if labels is not None and len(labels) > rows * cols:
            raise ParameterError(f"{len(labels)} labels for a grid of {rows * cols} cells")
        self.labels = None if labels is None else [str(s) for s in labels]
        self.ctx = create_context()
        try:
            self._setup(int(samples))
        except Exception:
            self.release()
            raise

    # -- GL setup ---------------------------------------------------------------------------
    def _setup(self, samples: int):
        import moderngl

        ctx = self.ctx
        model = _mesh.build_head_mesh(detail=1)
        self.prog = ctx.program(vertex_shader=_VERTEX_SHADER, fragment_shader=_FRAGMENT_SHADER)
        names = ["head", "ears", "neck", "torso"] + (["mask"] if self.mask else [])
        part = model.merged(names)
        self._vbo = ctx.buffer(part.interleaved().tobytes())
        self._ibo = ctx.buffer(part.indices.astype("u4").tobytes())
        self.vao = ctx.vertex_array(
            self.prog, [(self._vbo, "3f 3f 3f 1f 1f", "in_pos", "in_nrm", "in_col", "in_mat", "in_w")],
            index_buffer=self._ibo, index_element_size=4,
        )
        max_samples = ctx.max_samples
        self.samples = max(0, min(samples, max_samples))
        w, h = self.width, self.height
        if self.samples > 1:
            self._msaa = ctx.framebuffer(
                color_attachments=[ctx.renderbuffer((w, h), 4, samples=self.samples)],
                depth_attachment=ctx.depth_renderbuffer((w, h), samples=self.samples),
            )
            self._resolve = ctx.framebuffer(color_attachments=[ctx.renderbuffer((w, h), 4)])
        else:
            self._msaa = None
            self._resolve = ctx.framebuffer(
                color_attachments=[ctx.renderbuffer((w, h), 4)],
                depth_attachment=ctx.depth_renderbuffer((w, h)),
            )
        # camera: in front of the face, slightly above the eyes
        cw, ch = self.cell
        self.eye = np.array([0.0, 0.08, 0.86])
        view = _look_at(self.eye, (0.0, 0.045, 0.0))
        proj = _perspective(26.0, cw / ch, 0.1, 5.0)
        flip = np.diag([1.0, -1.0, 1.0, 1.0])  # rows come back top to bottom
        self.view_proj = flip @ proj @ view
        self.prog["u_viewproj"].write(self.view_proj.T.astype("f4").tobytes())
        self.prog["u_eye"].value = tuple(self.eye)
        self.prog["u_style"].value = STYLES.index(self.style)
        self._overlay = None
        if self.labels:
            self._make_overlay()
        self._moderngl = moderngl
        self._buf = bytearray(w * h * 3)

    def _make_overlay(self):
        from PIL import Image, ImageDraw, ImageFont

        w, h = self.width, self.height
        img = Image.new("RGBA", (w, h), (0, 0, 0, 0))
        draw = ImageDraw.Draw(img)
        cw, ch = self.cell
        fs = max(10, int(round(ch / 20)))
        font = ImageFont.load_default(size=fs)
        dark = self.style != "silhouette"
        for k, text in enumerate(self.labels):
            if not text:
                continue
            r, c = divmod(k, self.grid[1])
            x0, y0 = c * cw, r * ch
            bbox = draw.textbbox((0, 0), text, font=font)
            tw, th = bbox[2] - bbox[0], bbox[3] - bbox[1]
            pad = max(4, fs // 3)
            box = (x0 + pad, y0 + pad, x0 + pad + tw + 2 * pad, y0 + pad + th + 2 * pad)
            draw.rectangle(box, fill=(20, 20, 20, 170) if dark else (255, 255, 255, 200))
            draw.text((box[0] + pad - bbox[0], box[1] + pad - bbox[1]), text, font=font,
                      fill=(255, 255, 255, 255) if dark else (0, 0, 0, 255))
        ctx = self.ctx
        self._tex = ctx.texture((w, h), 4, img.tobytes())
        self._tex.filter = (self._moderngl_mod().NEAREST, self._moderngl_mod().NEAREST)
        prog = ctx.program(vertex_shader=_OVERLAY_VS, fragment_shader=_OVERLAY_FS)
        quad = np.array([-1, -1, 1, -1, -1, 1, 1, 1], dtype="f4")
        self._quad = ctx.buffer(quad.tobytes())
        self._overlay = ctx.vertex_array(prog, [(self._quad, "2f", "in_pos")])
        self._overlay_prog = prog

    @staticmethod
    def _moderngl_mod():
        import moderngl

        return moderngl

    # -- drawing ----------------------------------------------------------------------------
    def render_into(self, rotations, translations=None) -> bytearray:
        """Render one frame; returns the internal RGB buffer (rows top to bottom, reused!).

        Parameters
        ----------
        rotations : array [shape=(n_cells, 3)] rotation vectors (radians), or (n_cells, 3, 3)
            rotation matrices; fewer poses than cells leaves the other cells empty
        translations : array [shape=(n_cells, 3)] metres, or None
        """
        rots = np.asarray(rotations, dtype=np.float64)
        if rots.ndim == 1:
            rots = rots[None]
        if rots.ndim == 3 and rots.shape[1:] == (3, 3):
            from ..rotations import matrix_to_rotvec

            rots = matrix_to_rotvec(rots)
        if rots.ndim != 2 or rots.shape[1] != 3:
            raise ParameterError(f"rotations must be (n, 3) rotation vectors or (n, 3, 3) matrices; got {rots.shape}")
        n = len(rots)
        rows, cols = self.grid
        if n > rows * cols:
            raise ParameterError(f"{n} poses for a grid of {rows * cols} cells")
        tr = np.zeros((n, 3)) if translations is None else np.asarray(translations, float).reshape(n, 3)
        mgl = self._moderngl
        ctx = self.ctx
        target = self._msaa if self._msaa is not None else self._resolve
        target.use()
        ctx.viewport = (0, 0, self.width, self.height)
        ctx.clear(*_BACKGROUND[self.style], 1.0)
        ctx.enable(mgl.DEPTH_TEST)
        # every part is closed (or seen from outside only) and wound counter-clockwise; the
        # vertical flip of the projection turns that into clockwise on screen
        ctx.enable(mgl.CULL_FACE)
        ctx.front_face = "cw"
        cw, ch = self.cell
        u_rot = self.prog["u_rotvec"]
        u_trans = self.prog["u_trans"]
        for k in range(n):
            r, c = divmod(k, cols)
            ctx.viewport = (c * cw, r * ch, cw, ch)
            u_rot.value = tuple(float(v) for v in rots[k])
            u_trans.value = tuple(float(v) for v in tr[k])
            self.vao.render(mgl.TRIANGLES)
        if self._overlay is not None:
            ctx.viewport = (0, 0, self.width, self.height)
            ctx.disable(mgl.DEPTH_TEST | mgl.CULL_FACE)
            ctx.enable(mgl.BLEND)
            ctx.blend_func = mgl.SRC_ALPHA, mgl.ONE_MINUS_SRC_ALPHA
            self._tex.use(0)
            self._overlay.render(mgl.TRIANGLE_STRIP)
            ctx.disable(mgl.BLEND)
        if self._msaa is not None:
            ctx.copy_framebuffer(self._resolve, self._msaa)
        self._resolve.read_into(self._buf, components=3, alignment=1)
        return self._buf

    def render(self, rotations, translations=None) -> np.ndarray:
        """Render one frame and return a copy, ``(height, width, 3)`` uint8, rows top to bottom."""
        buf = self.render_into(rotations, translations)
        return np.frombuffer(bytes(buf), np.uint8).reshape(self.height, self.width, 3)

    def release(self):
        """Free the GL context (also done when the object is garbage collected)."""
        ctx = getattr(self, "ctx", None)
        if ctx is not None:
            try:
                ctx.release()
            except Exception:
                pass
            self.ctx = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()

    def __del__(self):
        self.release()


def render_pose(rotvec=(0.0, 0.0, 0.0), *, size=(640, 480), style: str = "textured",
                mask: bool = True, translation=None) -> np.ndarray:
    """One still image of the head at ``rotvec`` (radians), ``(H, W, 3)`` uint8."""
    with HeadRenderer(size=size, style=style, mask=mask) as r:
        return r.render(np.asarray(rotvec, float)[None],
                        None if translation is None else np.asarray(translation, float)[None])


__all__ = ["HeadRenderer", "STYLES", "render_pose", "parse_size", "create_context"]
