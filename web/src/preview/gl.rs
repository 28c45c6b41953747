//! The WebGL2 renderer: thin glue between the plain maths ([`super::camera`],
//! [`super::scene`]) and the GPU.
//!
//! One draw of point sprites for all balls: one vertex a ball, the sprite a square
//! of pixels holding the ball's silhouette, on which the fragment shader traces the
//! exact sphere along each pixel's ray (a lit impostor, round at any distance, with
//! its true depth), Lambert plus ambient as [`super::scene::lit`]. A ball too big on
//! screen for a sprite (past the WebGL's largest point, or [`SPRITE_LIMIT_PX`]) is
//! drawn as a camera-facing quad by a second draw, made only when the nearest ball
//! may be that big. Then one draw of lines for the cables, from each ball up to its
//! anchor (after the balls, so that the depth test drops what they hide), and plain
//! lines for the ceiling grid and the floor reference.
//!
//! A dense view (neighbouring balls closer than [`DENSE_PITCH_PX`] on screen where
//! they are nearest, as 10,000 balls seen whole at 640 × 480) is drawn more
//! cheaply, SwiftShader paying for every primitive and every shader instruction: the
//! balls as point sprites of flat-lit discs (lit as a sphere seen from in front, at
//! the centre's depth, no ray traced: balls a few pixels across, where that is what
//! the traced sphere shows too); only every k-th cable of every k-th row, and grid lines through every k-th row and column, k
//! the smallest that keeps them [`DENSE_CABLE_SPACING_PX`] apart ([`stride_for`]).
//! Anything sparser is drawn in full, as above.
//!
//! The per-ball data goes to the GPU as one small RG32F texture, one upload a frame:
//! the height of the ball's centre and its colour packed in one float; where it
//! hangs follows from its index and the grid, given once per scene. The vertex
//! shaders fetch their ball's texel by `gl_VertexID` ("vertex pulling"), without
//! instancing, which SwiftShader (the software renderer of headless Chromium and of
//! machines without a usable GPU) runs one instance at a time. On SwiftShader every
//! primitive has a cost of its own, hence one point a ball rather than two triangles
//! (and cables, 10,000 lines at 100 × 100, are the larger part of such a frame). Nothing is allocated in Rust per frame, and what
//! stays the same (colours, the light's share, the sampler's unit) is set once.
//! Edges are smoothed by multisampling, except on a software renderer, where it
//! would cost several times the frame.
//!
//! The canvas keeps its picture (`preserveDrawingBuffer`) so that tests and snapshots
//! can read it back.

use glam::{Mat4, Vec3};
use wasm_bindgen::JsCast;
use web_sys::{
    HtmlCanvasElement, WebGl2RenderingContext as Gl, WebGlBuffer, WebGlProgram, WebGlShader,
    WebGlTexture, WebGlUniformLocation, WebGlVertexArrayObject,
};

use super::camera::Viewport;
use super::scene::{AMBIENT, Scene};

/// The canvas background, 0–1 (`#0b1117`, as the top view's).
const BACKGROUND: [f32; 3] = [11.0 / 255.0, 17.0 / 255.0, 23.0 / 255.0];
/// Line colours, 0–1.
const CEILING_COLOUR: [f32; 3] = [0.50, 0.58, 0.65];
const FLOOR_COLOUR: [f32; 3] = [0.22, 0.29, 0.35];
const CABLE_COLOUR: [f32; 3] = [0.45, 0.50, 0.55];
/// The rim of the ball chosen for the plot (the app's accent colour), 0–1.
const SELECTED_COLOUR: [f32; 3] = [0.25, 0.65, 0.96];

const BALL_VERTEX: &str = r"#version 300 es
uniform highp sampler2D u_balls;
uniform mat4 u_clip_from_world;
uniform vec3 u_eye;
uniform int u_selected;
uniform int u_cols;
uniform vec3 u_grid;
uniform float u_radius;
uniform vec2 u_viewport;
uniform float u_max_sprite;
uniform bool u_quads;
flat out vec4 v_ball;
flat out vec3 v_colour;
flat out float v_selected;
const vec2 CORNERS[4] = vec2[4](vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(-1.0, 1.0), vec2(1.0, 1.0));
void main() {
    int ball = u_quads ? gl_VertexID / 4 : gl_VertexID;
    int width = textureSize(u_balls, 0).x;
    vec2 texel = texelFetch(u_balls, ivec2(ball % width, ball / width), 0).xy;
    vec3 centre = vec3(
        (float(ball % u_cols) - u_grid.x) * u_grid.z,
        texel.x,
        (float(ball / u_cols) - u_grid.y) * u_grid.z);
    uint rgb = uint(texel.y);
    v_colour = vec3(uvec3(rgb >> 16, rgb >> 8, rgb) & 255u) / 255.0;
    v_ball = vec4(centre, u_radius);
    v_selected = ball == u_selected ? 1.0 : 0.0;
    // Not drawn unless placed below (outside the clip volume).
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);
    gl_PointSize = 1.0;
    vec3 to_eye = u_eye - centre;
    float d = length(to_eye);
    float r = u_radius;
    if (d <= r * 1.001) return;
    vec3 n = to_eye / d;
    vec3 side = abs(n.y) > 0.999 ? vec3(1.0, 0.0, 0.0) : normalize(cross(vec3(0.0, 1.0, 0.0), n));
    vec3 up = cross(n, side);
    // The cone from the eye touching the sphere cuts the plane through the centre
    // in a circle of this radius: a square of twice it holds the whole silhouette.
    float h = r * d / sqrt(d * d - r * r) * 1.02;
    vec4 c = u_clip_from_world * vec4(centre, 1.0);
    vec4 s = u_clip_from_world * vec4(side * h, 0.0);
    vec4 u = u_clip_from_world * vec4(up * h, 0.0);
    // The sprite: a square of pixels around the centre's holding that square's corners.
    bool behind = c.w <= 0.0;
    vec2 centre_ndc = c.xy / c.w;
    vec2 half_ndc = vec2(0.0);
    for (int i = 0; i < 4; i++) {
        vec4 k = c + s * CORNERS[i].x + u * CORNERS[i].y;
        behind = behind || k.w <= 0.0;
        half_ndc = max(half_ndc, abs(k.xy / k.w - centre_ndc));
    }
    vec2 half_px = half_ndc * u_viewport * 0.5;
    float size = ceil(2.0 * max(half_px.x, half_px.y)) + 1.0;
    bool sprite = !behind && size <= u_max_sprite;
    if (u_quads) {
        // Only the balls too big (or too near) for a sprite, with a band drawn both ways.
        if (sprite && size < u_max_sprite - 4.0) return;
        vec2 corner = CORNERS[gl_VertexID % 4];
        gl_Position = c + s * corner.x + u * corner.y;
        return;
    }
    if (!sprite) return;
    // A point whose centre is outside the view is not drawn at all: one half out is
    // drawn from the nearest pixel inside, as large, which still covers what shows.
    vec2 px = (centre_ndc * 0.5 + 0.5) * u_viewport;
    vec2 inside = clamp(px, vec2(0.5), u_viewport - 0.5);
    if (any(greaterThan(abs(inside - px), vec2(size * 0.5)))) return;
    gl_Position = vec4(inside / u_viewport * 2.0 - 1.0, clamp(c.z / c.w, -1.0, 1.0), 1.0);
    gl_PointSize = size;
}
";

const BALL_FRAGMENT: &str = r"#version 300 es
precision highp float;
flat in vec4 v_ball;
flat in vec3 v_colour;
flat in float v_selected;
uniform vec3 u_ray[3];
uniform vec4 u_depth[2];
uniform vec3 u_eye;
uniform vec3 u_light;
uniform float u_ambient;
uniform vec3 u_selected_colour;
out vec4 o_colour;
void main() {
    // The ray from the eye through this pixel (affine in the pixel's position).
    vec3 dir = normalize(u_ray[0] + u_ray[1] * gl_FragCoord.x + u_ray[2] * gl_FragCoord.y);
    vec3 from_centre = u_eye - v_ball.xyz;
    float b = dot(from_centre, dir);
    float c = dot(from_centre, from_centre) - v_ball.w * v_ball.w;
    float disc = b * b - c;
    if (disc < 0.0) discard;
    vec3 hit = u_eye + dir * (-b - sqrt(disc));
    vec3 n = (hit - v_ball.xyz) / v_ball.w;
    vec3 rgb = v_colour * (u_ambient + (1.0 - u_ambient) * max(dot(n, u_light), 0.0));
    float edge = 1.0 - max(dot(n, -dir), 0.0);
    rgb = mix(rgb, u_selected_colour, edge * edge * v_selected);
    o_colour = vec4(rgb, 1.0);
    // The clip space z and w rows of the projection.
    vec4 at = vec4(hit, 1.0);
    gl_FragDepth = clamp(dot(u_depth[0], at) / dot(u_depth[1], at) * 0.5 + 0.5, 0.0, 1.0);
}
";

const CABLE_VERTEX: &str = r"#version 300 es
uniform highp sampler2D u_balls;
uniform mat4 u_clip_from_world;
uniform int u_cols;
uniform vec3 u_grid;
uniform float u_radius;
uniform int u_stride;
uniform int u_units;
void main() {
    // The cable of every `u_stride`-th ball of every `u_stride`-th row (all of
    // them at 1).
    int line = gl_VertexID / 2;
    int per_row = (u_cols + u_stride - 1) / u_stride;
    int ball = (line / per_row) * u_stride * u_cols + (line % per_row) * u_stride;
    if (ball >= u_units) {
        gl_Position = vec4(0.0, 0.0, 2.0, 1.0);
        return;
    }
    int width = textureSize(u_balls, 0).x;
    float y = texelFetch(u_balls, ivec2(ball % width, ball / width), 0).x;
    vec3 anchor = vec3(
        (float(ball % u_cols) - u_grid.x) * u_grid.z,
        0.0,
        (float(ball / u_cols) - u_grid.y) * u_grid.z);
    vec3 top_of_ball = vec3(anchor.x, y + u_radius, anchor.z);
    gl_Position = u_clip_from_world * vec4(gl_VertexID % 2 == 0 ? anchor : top_of_ball, 1.0);
}
";

/// Dense views: one point sprite a ball holding a flat-lit disc, the cheapest
/// shaders that draw it.
const DOT_VERTEX: &str = r"#version 300 es
uniform highp sampler2D u_balls;
uniform mat4 u_clip_from_world;
uniform int u_cols;
uniform vec3 u_grid;
uniform float u_radius;
uniform float u_focal_px;
uniform int u_selected;
flat out vec3 v_colour;
flat out float v_selected;
// From the sprite's coordinates (-1 to 1) to the disc's (1 at its rim).
flat out float v_scale;
void main() {
    int ball = gl_VertexID;
    int width = textureSize(u_balls, 0).x;
    vec2 texel = texelFetch(u_balls, ivec2(ball % width, ball / width), 0).xy;
    vec3 centre = vec3(
        (float(ball % u_cols) - u_grid.x) * u_grid.z,
        texel.x,
        (float(ball / u_cols) - u_grid.y) * u_grid.z);
    uint rgb = uint(texel.y);
    v_colour = vec3(uvec3(rgb >> 16, rgb >> 8, rgb) & 255u) / 255.0;
    v_selected = ball == u_selected ? 1.0 : 0.0;
    vec4 c = u_clip_from_world * vec4(centre, 1.0);
    float r = u_radius * u_focal_px / max(c.w, 1e-6);
    float size = ceil(2.0 * r) + 1.0;
    v_scale = size / (2.0 * r);
    gl_Position = c;
    gl_PointSize = size;
}
";

const DOT_FRAGMENT: &str = r"#version 300 es
precision highp float;
flat in vec3 v_colour;
flat in float v_selected;
flat in float v_scale;
uniform vec3 u_light_view;
uniform float u_ambient;
uniform vec3 u_selected_colour;
out vec4 o_colour;
void main() {
    vec2 p = (gl_PointCoord * 2.0 - 1.0) * vec2(v_scale, -v_scale);
    float d2 = dot(p, p);
    if (d2 >= 1.0) discard;
    // The sphere's normal there, in the camera's frame (right, up, back).
    vec3 n = vec3(p, sqrt(1.0 - d2));
    vec3 rgb = v_colour * (u_ambient + (1.0 - u_ambient) * max(dot(n, u_light_view), 0.0));
    float edge = 1.0 - n.z;
    o_colour = vec4(mix(rgb, u_selected_colour, edge * edge * v_selected), 1.0);
}
";

const LINE_VERTEX: &str = r"#version 300 es
layout(location = 0) in vec3 a_position;
uniform mat4 u_clip_from_world;
void main() {
    gl_Position = u_clip_from_world * vec4(a_position, 1.0);
}
";

const FLAT_FRAGMENT: &str = r"#version 300 es
precision mediump float;
uniform vec3 u_colour;
out vec4 o_colour;
void main() {
    o_colour = vec4(u_colour, 1.0);
}
";

/// What one frame shows.
#[derive(Debug, Clone, Copy)]
pub struct FrameView<'a> {
    /// World to clip space.
    pub clip_from_world: Mat4,
    /// The eye, metres.
    pub eye: Vec3,
    /// Towards the light, length 1.
    pub light: Vec3,
    /// The canvas, pixels.
    pub viewport: Viewport,
    /// Per ball, two numbers: the height of its centre, metres (the grid at 0, down
    /// negative), and its colour as `0xRRGGBB` (see [`pack_colour`]).
    pub balls: &'a [f32],
    /// The ball to mark, if any.
    pub selected: Option<usize>,
}

/// A ball's colour as one float (`0xRRGGBB`: exact, as every integer below 2²⁴ is),
/// the way [`FrameView::balls`] carries it.
pub fn pack_colour([r, g, b]: [u8; 3]) -> f32 {
    ((u32::from(r) << 16) | (u32::from(g) << 8) | u32::from(b)) as f32
}

/// A linked program and its uniforms.
#[derive(Debug)]
struct Program {
    program: WebGlProgram,
    clip_from_world: Option<WebGlUniformLocation>,
    /// Where ball `i` hangs: columns per row; the middle column and row and the
    /// pitch; the balls' radius.
    cols: Option<WebGlUniformLocation>,
    grid: Option<WebGlUniformLocation>,
    radius: Option<WebGlUniformLocation>,
}

impl Program {
    fn new(gl: &Gl, vertex: &str, fragment: &str) -> Result<Self, String> {
        let vertex = shader(gl, Gl::VERTEX_SHADER, vertex)?;
        let fragment = shader(gl, Gl::FRAGMENT_SHADER, fragment)?;
        let program = gl.create_program().ok_or("cannot create a program")?;
        gl.attach_shader(&program, &vertex);
        gl.attach_shader(&program, &fragment);
        gl.link_program(&program);
        if !gl
            .get_program_parameter(&program, Gl::LINK_STATUS)
            .as_bool()
            .unwrap_or(false)
        {
            return Err(gl.get_program_info_log(&program).unwrap_or_default());
        }
        let at = |name| gl.get_uniform_location(&program, name);
        Ok(Self {
            clip_from_world: at("u_clip_from_world"),
            cols: at("u_cols"),
            grid: at("u_grid"),
            radius: at("u_radius"),
            program,
        })
    }

    fn uniform(&self, gl: &Gl, name: &str) -> Option<WebGlUniformLocation> {
        gl.get_uniform_location(&self.program, name)
    }

    /// Makes this the program in use, with the frame's matrix.
    fn use_with(&self, gl: &Gl, clip_from_world: &Mat4) {
        gl.use_program(Some(&self.program));
        gl.uniform_matrix4fv_with_f32_array(
            self.clip_from_world.as_ref(),
            false,
            &clip_from_world.to_cols_array(),
        );
    }

    /// Tells the program where the balls hang (once per scene).
    fn set_grid(&self, gl: &Gl, scene: &Scene) {
        let (cols, rows, pitch_m) = scene.grid();
        gl.use_program(Some(&self.program));
        gl.uniform1i(self.cols.as_ref(), cols as i32);
        gl.uniform3f(
            self.grid.as_ref(),
            (cols as f32 - 1.0) / 2.0,
            (rows as f32 - 1.0) / 2.0,
            pitch_m,
        );
        gl.uniform1f(self.radius.as_ref(), scene.ball_radius_m);
    }
}

fn shader(gl: &Gl, kind: u32, source: &str) -> Result<WebGlShader, String> {
    let shader = gl.create_shader(kind).ok_or("cannot create a shader")?;
    gl.shader_source(&shader, source);
    gl.compile_shader(&shader);
    if gl
        .get_shader_parameter(&shader, Gl::COMPILE_STATUS)
        .as_bool()
        .unwrap_or(false)
    {
        Ok(shader)
    } else {
        Err(gl.get_shader_info_log(&shader).unwrap_or_default())
    }
}

/// A buffer of line segments and the vertex array that reads it.
#[derive(Debug)]
struct Lines {
    vao: WebGlVertexArrayObject,
    buffer: WebGlBuffer,
    vertices: i32,
}

impl Lines {
    fn delete(self, gl: &Gl) {
        gl.delete_vertex_array(Some(&self.vao));
        gl.delete_buffer(Some(&self.buffer));
    }
}

/// Balls per row of the per-ball texture (every WebGL2 allows 2048).
const TEXELS_PER_ROW: usize = 1024;

/// The per-ball texture (RG32F: height and packed colour), the JS-side array it is
/// filled from, and the indices of the balls' quads (for balls too big for a sprite).
#[derive(Debug)]
struct BallTexture {
    /// Two triangles a ball: `4b, 4b+1, 4b+2` and `4b+2, 4b+1, 4b+3`.
    indices: WebGlBuffer,
    texture: WebGlTexture,
    staging: js_sys::Float32Array,
    /// Texture width and height, texels.
    width: usize,
    height: usize,
}

impl BallTexture {
    fn new(gl: &Gl, units: usize) -> Result<Self, String> {
        let width = units.clamp(1, TEXELS_PER_ROW);
        let height = units.div_ceil(width).max(1);
        let texture = gl.create_texture().ok_or("cannot create a texture")?;
        gl.active_texture(Gl::TEXTURE0);
        gl.bind_texture(Gl::TEXTURE_2D, Some(&texture));
        gl.tex_storage_2d(Gl::TEXTURE_2D, 1, Gl::RG32F, width as i32, height as i32);
        gl.tex_parameteri(Gl::TEXTURE_2D, Gl::TEXTURE_MIN_FILTER, Gl::NEAREST as i32);
        gl.tex_parameteri(Gl::TEXTURE_2D, Gl::TEXTURE_MAG_FILTER, Gl::NEAREST as i32);
        let texels = u32::try_from(width * height).map_err(|_| "too many balls")?;
        let indices: Vec<u32> = (0..texels)
            .flat_map(|ball| {
                let first = ball * 4;
                [first, first + 1, first + 2, first + 2, first + 1, first + 3]
            })
            .collect();
        let buffer = gl.create_buffer().ok_or("cannot create a buffer")?;
        gl.bind_buffer(Gl::ELEMENT_ARRAY_BUFFER, Some(&buffer));
        gl.buffer_data_with_array_buffer_view(
            Gl::ELEMENT_ARRAY_BUFFER,
            &js_sys::Uint32Array::from(indices.as_slice()),
            Gl::STATIC_DRAW,
        );
        Ok(Self {
            indices: buffer,
            texture,
            staging: js_sys::Float32Array::new_with_length(texels * 2),
            width,
            height,
        })
    }

    fn capacity(&self) -> usize {
        self.width * self.height
    }

    fn delete(self, gl: &Gl) {
        gl.delete_buffer(Some(&self.indices));
        gl.delete_texture(Some(&self.texture));
    }

    /// Uploads the first `units` balls, whole rows at a time: one upload a frame.
    fn upload(&self, gl: &Gl, units: usize, balls: &[f32]) {
        let rows = units.div_ceil(self.width);
        let texels = (rows * self.width) as u32;
        self.staging
            .subarray(0, (units * 2) as u32)
            .copy_from(&balls[..units * 2]);
        let pixels: js_sys::Object = self.staging.subarray(0, texels * 2).into();
        // The texture stays bound to unit 0.
        // A failed upload leaves last frame's balls; WebGL reports it on the console.
        let _ = gl.tex_sub_image_2d_with_i32_and_i32_and_u32_and_type_and_opt_array_buffer_view(
            Gl::TEXTURE_2D,
            0,
            0,
            0,
            self.width as i32,
            rows as i32,
            Gl::RG,
            Gl::FLOAT,
            Some(&pixels),
        );
    }
}

/// The renderer of one canvas.
#[derive(Debug)]
pub struct GlView {
    gl: Gl,
    balls: Program,
    ball_uniforms: BallUniforms,
    /// Dense views: the balls as flat-lit discs.
    dots: Program,
    dot_uniforms: DotUniforms,
    cables: Program,
    cable_uniforms: CableUniforms,
    lines: Program,
    /// The grid lines' colour.
    line_colour: Option<WebGlUniformLocation>,
    /// Drawn with while vertices come from the texture (holds the quads' index buffer).
    no_attributes: WebGlVertexArrayObject,
    texture: Option<BallTexture>,
    ceiling: Option<Lines>,
    floor: Option<Lines>,
    /// The grid lines drawn run through every `grid_stride`-th row and column.
    grid_stride: usize,
    /// Where the balls hang.
    scene: Option<Scene>,
    /// The largest point sprite this WebGL draws, pixels.
    max_sprite_px: f32,
}

/// The balls program's own uniforms.
#[derive(Debug)]
struct BallUniforms {
    ray: Option<WebGlUniformLocation>,
    depth: Option<WebGlUniformLocation>,
    eye: Option<WebGlUniformLocation>,
    light: Option<WebGlUniformLocation>,
    viewport: Option<WebGlUniformLocation>,
    selected: Option<WebGlUniformLocation>,
    quads: Option<WebGlUniformLocation>,
}

/// The dot program's own uniforms.
#[derive(Debug)]
struct DotUniforms {
    focal: Option<WebGlUniformLocation>,
    selected: Option<WebGlUniformLocation>,
    light_view: Option<WebGlUniformLocation>,
}

/// The cable program's own uniforms.
#[derive(Debug)]
struct CableUniforms {
    stride: Option<WebGlUniformLocation>,
    units: Option<WebGlUniformLocation>,
}

/// How far apart, on screen, neighbouring balls at least are for the view to be
/// drawn in full (pixels between the nearest ball and its neighbour); closer than
/// that, the view is dense: the balls are drawn as flat-lit discs, and only every k-th cable and grid line ([`stride_for`]).
pub const DENSE_PITCH_PX: f32 = 8.0;
/// How far apart, on screen, the cables and grid lines drawn in a dense view at least
/// are (pixels, where the balls are nearest).
pub const DENSE_CABLE_SPACING_PX: f32 = 16.0;
/// The most balls (in each direction) one drawn cable stands for in a dense view.
pub const MAX_STRIDE: usize = 8;

/// Every how many rows and columns a cable and a grid line are drawn when
/// neighbouring balls are `pitch_px` apart on screen: 1 (all) at [`DENSE_PITCH_PX`]
/// and more; below, the smallest (at least 2, at most [`MAX_STRIDE`]) that keeps
/// them [`DENSE_CABLE_SPACING_PX`] apart.
pub fn stride_for(pitch_px: f32) -> usize {
    if pitch_px.is_nan() || pitch_px >= DENSE_PITCH_PX {
        1
    } else {
        ((DENSE_CABLE_SPACING_PX / pitch_px.max(1e-3)).ceil() as usize).clamp(2, MAX_STRIDE)
    }
}

/// The largest sprite drawn as a point even when the WebGL allows more, pixels
/// (larger balls are few and drawn as quads).
const SPRITE_LIMIT_PX: f32 = 256.0;

impl GlView {
    /// A WebGL2 renderer on `canvas`; an error (no WebGL2, a shader that does not
    /// compile) says why there is none.
    pub fn new(canvas: &HtmlCanvasElement) -> Result<Self, String> {
        let options = js_sys::Object::new();
        for (key, value) in [
            ("alpha", false),
            ("antialias", !software_renderer()),
            ("preserveDrawingBuffer", true),
        ] {
            js_sys::Reflect::set(&options, &key.into(), &value.into())
                .map_err(|_| "cannot set the context options")?;
        }
        let gl: Gl = canvas
            .get_context_with_context_options("webgl2", &options)
            .ok()
            .flatten()
            .ok_or("this browser has no WebGL2")?
            .dyn_into()
            .map_err(|_| "not a WebGL2 context")?;

        let balls = Program::new(&gl, BALL_VERTEX, BALL_FRAGMENT)?;
        let ball_uniforms = BallUniforms {
            ray: balls.uniform(&gl, "u_ray"),
            depth: balls.uniform(&gl, "u_depth"),
            eye: balls.uniform(&gl, "u_eye"),
            light: balls.uniform(&gl, "u_light"),
            viewport: balls.uniform(&gl, "u_viewport"),
            selected: balls.uniform(&gl, "u_selected"),
            quads: balls.uniform(&gl, "u_quads"),
        };
        let dots = Program::new(&gl, DOT_VERTEX, DOT_FRAGMENT)?;
        let dot_uniforms = DotUniforms {
            focal: dots.uniform(&gl, "u_focal_px"),
            selected: dots.uniform(&gl, "u_selected"),
            light_view: dots.uniform(&gl, "u_light_view"),
        };
        let cables = Program::new(&gl, CABLE_VERTEX, FLAT_FRAGMENT)?;
        let cable_uniforms = CableUniforms {
            stride: cables.uniform(&gl, "u_stride"),
            units: cables.uniform(&gl, "u_units"),
        };
        let lines = Program::new(&gl, LINE_VERTEX, FLAT_FRAGMENT)?;
        // The largest point this WebGL draws (at least 1 by the standard).
        let max_sprite_px = gl
            .get_parameter(Gl::ALIASED_POINT_SIZE_RANGE)
            .ok()
            .and_then(|range| js_sys::Reflect::get(&range, &1.into()).ok())
            .and_then(|max| max.as_f64())
            .map_or(1.0, |max| max as f32)
            .min(SPRITE_LIMIT_PX);
        // What stays the same for every frame: the sampler reads texture unit 0, the
        // colours and the light's share.
        gl.use_program(Some(&balls.program));
        gl.uniform1i(balls.uniform(&gl, "u_balls").as_ref(), 0);
        gl.uniform1f(balls.uniform(&gl, "u_ambient").as_ref(), AMBIENT);
        gl.uniform1f(balls.uniform(&gl, "u_max_sprite").as_ref(), max_sprite_px);
        gl.uniform3fv_with_f32_array(
            balls.uniform(&gl, "u_selected_colour").as_ref(),
            &SELECTED_COLOUR,
        );
        gl.use_program(Some(&dots.program));
        gl.uniform1i(dots.uniform(&gl, "u_balls").as_ref(), 0);
        gl.uniform1f(dots.uniform(&gl, "u_ambient").as_ref(), AMBIENT);
        gl.uniform3fv_with_f32_array(
            dots.uniform(&gl, "u_selected_colour").as_ref(),
            &SELECTED_COLOUR,
        );
        gl.use_program(Some(&cables.program));
        gl.uniform1i(cables.uniform(&gl, "u_balls").as_ref(), 0);
        gl.uniform3fv_with_f32_array(cables.uniform(&gl, "u_colour").as_ref(), &CABLE_COLOUR);
        let line_colour = lines.uniform(&gl, "u_colour");
        let no_attributes = gl
            .create_vertex_array()
            .ok_or("cannot create a vertex array")?;
        gl.enable(Gl::DEPTH_TEST);
        let [r, g, b] = BACKGROUND;
        gl.clear_color(r, g, b, 1.0);

        Ok(Self {
            gl,
            balls,
            ball_uniforms,
            dots,
            dot_uniforms,
            cables,
            cable_uniforms,
            lines,
            line_colour,
            no_attributes,
            texture: None,
            ceiling: None,
            floor: None,
            grid_stride: 1,
            scene: None,
            max_sprite_px,
        })
    }

    /// Prepares the texture and the grid for `scene` with `units` balls (each show;
    /// nothing to do when the matrix is the same).
    pub fn set_scene(&mut self, scene: &Scene, units: usize) -> Result<(), String> {
        let fits = self
            .texture
            .as_ref()
            .is_some_and(|texture| texture.capacity() >= units);
        if fits && self.scene.as_ref() == Some(scene) {
            // The same matrix (a show regenerated while a slider moves): its buffers
            // and grid lines stand.
            return Ok(());
        }
        let gl = &self.gl;
        if self
            .texture
            .as_ref()
            .is_none_or(|texture| texture.capacity() < units)
        {
            if let Some(old) = self.texture.take() {
                old.delete(gl);
            }
            self.texture = Some(BallTexture::new(gl, units)?);
        }
        self.balls.set_grid(gl, scene);
        self.dots.set_grid(gl, scene);
        self.cables.set_grid(gl, scene);
        self.scene = Some(*scene);
        self.set_grid_stride(1)
    }

    /// Makes the grid lines run through every `stride`-th row and column.
    fn set_grid_stride(&mut self, stride: usize) -> Result<(), String> {
        let gl = &self.gl;
        for old in [self.ceiling.take(), self.floor.take()]
            .into_iter()
            .flatten()
        {
            old.delete(gl);
        }
        self.grid_stride = stride;
        let Some(scene) = self.scene else {
            return Ok(());
        };
        let (ceiling, floor) = scene.grid_lines_every(stride);
        self.ceiling = Some(lines(gl, &ceiling)?);
        self.floor = Some(lines(gl, &floor)?);
        Ok(())
    }

    /// Whether some ball of `frame` may be too big on screen for a point sprite: a
    /// generous bound from the nearest ball, `nearest_sq` m² from the eye (the vertex
    /// shader decides exactly).
    fn needs_quads(&self, frame: &FrameView, nearest_sq: f32) -> bool {
        let Some(scene) = self.scene else {
            return false;
        };
        let r = scene.ball_radius_m;
        if nearest_sq <= r * r * 1.01 {
            return true;
        }
        // Pixels per radian at the middle of the view (a vertical field of 45°); a
        // sprite grows by at most 1/cos² towards the view's corners, √2 for a turned
        // square.
        let focal_px = frame.viewport.height / 2.0 / (std::f32::consts::FRAC_PI_8).tan();
        let half_px = focal_px * r / (nearest_sq - r * r).sqrt() * 1.02 * 2f32.sqrt() / 0.4;
        2.0 * half_px + 4.0 > self.max_sprite_px - 8.0
    }

    /// The squared distance from the eye to the nearest of the first `units` balls'
    /// centres (infinite for none).
    fn nearest_sq(&self, frame: &FrameView, units: usize) -> f32 {
        let Some(scene) = self.scene else {
            return f32::INFINITY;
        };
        (0..units)
            .map(|unit| {
                let anchor = scene.anchor(unit);
                let centre = Vec3::new(anchor.x, frame.balls[unit * 2], anchor.z);
                centre.distance_squared(frame.eye)
            })
            .fold(f32::INFINITY, f32::min)
    }

    /// Pixels per metre at one metre from the eye (the projection's vertical scale).
    fn focal_px(frame: &FrameView) -> f32 {
        frame.clip_from_world.row(1).truncate().length() * frame.viewport.height / 2.0
    }

    /// Every how many rows and columns the cables and grid lines of `frame` are
    /// drawn (see [`stride_for`]): from how far apart neighbouring balls are on
    /// screen where they are nearest.
    fn stride(&self, frame: &FrameView, nearest_sq: f32) -> usize {
        let Some(scene) = self.scene else {
            return 1;
        };
        let (_, _, pitch_m) = scene.grid();
        stride_for(pitch_m * Self::focal_px(frame) / nearest_sq.sqrt())
    }

    /// Draws a frame: the balls as point sprites (quads for any too big for one),
    /// then what they may hide, the cables and the grid. A dense view (see
    /// [`DENSE_PITCH_PX`]) draws the balls as flat-lit discs and every k-th cable and
    /// grid line.
    pub fn draw(&mut self, frame: &FrameView) {
        let units =
            (frame.balls.len() / 2).min(self.texture.as_ref().map_or(0, BallTexture::capacity));
        let nearest_sq = self.nearest_sq(frame, units);
        let stride = self.stride(frame, nearest_sq);
        if stride != self.grid_stride {
            // A failure leaves no grid; WebGL reports it on the console.
            let _ = self.set_grid_stride(stride);
        }
        let gl = &self.gl;
        gl.viewport(
            0,
            0,
            frame.viewport.width as i32,
            frame.viewport.height as i32,
        );
        gl.clear(Gl::COLOR_BUFFER_BIT | Gl::DEPTH_BUFFER_BIT);

        let matrix = &frame.clip_from_world;
        if let Some(texture) = self.texture.as_ref().filter(|_| units > 0) {
            texture.upload(gl, units, frame.balls);
            gl.bind_vertex_array(Some(&self.no_attributes));
            if stride > 1 {
                self.draw_dots(frame, units);
            } else {
                self.draw_balls(frame, texture, units, nearest_sq);
            }
            // After the balls: the depth test drops what they hide before shading.
            self.cables.use_with(gl, matrix);
            gl.uniform1i(self.cable_uniforms.stride.as_ref(), stride as i32);
            gl.uniform1i(self.cable_uniforms.units.as_ref(), units as i32);
            let cables = if stride == 1 {
                units
            } else {
                let (cols, _, _) = self.scene.map_or((1, 1, 0.0), |scene| scene.grid());
                let cols = cols.max(1) as usize;
                cols.div_ceil(stride) * units.div_ceil(cols).div_ceil(stride)
            };
            gl.draw_arrays(Gl::LINES, 0, (cables * 2) as i32);
        }
        self.lines.use_with(gl, matrix);
        for (lines, colour) in [(&self.ceiling, CEILING_COLOUR), (&self.floor, FLOOR_COLOUR)] {
            if let Some(lines) = lines {
                gl.uniform3fv_with_f32_array(self.line_colour.as_ref(), &colour);
                gl.bind_vertex_array(Some(&lines.vao));
                gl.draw_arrays(Gl::LINES, 0, lines.vertices);
            }
        }
        gl.bind_vertex_array(None);
    }

    /// The balls: one point sprite each, then quads for those too big for one.
    fn draw_balls(&self, frame: &FrameView, texture: &BallTexture, units: usize, nearest_sq: f32) {
        let gl = &self.gl;
        let matrix = &frame.clip_from_world;
        self.balls.use_with(gl, matrix);
        let uniforms = &self.ball_uniforms;
        gl.uniform3fv_with_f32_array(uniforms.ray.as_ref(), &pixel_rays(frame));
        let rows = [matrix.row(2).to_array(), matrix.row(3).to_array()];
        gl.uniform4fv_with_f32_array(uniforms.depth.as_ref(), rows.as_flattened());
        gl.uniform3fv_with_f32_array(uniforms.eye.as_ref(), &frame.eye.to_array());
        gl.uniform3fv_with_f32_array(uniforms.light.as_ref(), &frame.light.to_array());
        gl.uniform2f(
            uniforms.viewport.as_ref(),
            frame.viewport.width,
            frame.viewport.height,
        );
        let selected = frame
            .selected
            .and_then(|unit| i32::try_from(unit).ok())
            .unwrap_or(-1);
        gl.uniform1i(uniforms.selected.as_ref(), selected);
        gl.uniform1i(uniforms.quads.as_ref(), 0);
        gl.draw_arrays(Gl::POINTS, 0, units as i32);
        if self.needs_quads(frame, nearest_sq) {
            gl.uniform1i(uniforms.quads.as_ref(), 1);
            gl.bind_buffer(Gl::ELEMENT_ARRAY_BUFFER, Some(&texture.indices));
            gl.draw_elements_with_i32(Gl::TRIANGLES, (units * 6) as i32, Gl::UNSIGNED_INT, 0);
        }
    }

    /// A dense view's balls: one point sprite each holding a disc, lit as a sphere seen
    /// from in front (at a few pixels across, the same as the traced sphere), at the
    /// centre's depth.
    fn draw_dots(&self, frame: &FrameView, units: usize) {
        let gl = &self.gl;
        self.dots.use_with(gl, &frame.clip_from_world);
        let uniforms = &self.dot_uniforms;
        gl.uniform1f(uniforms.focal.as_ref(), Self::focal_px(frame));
        let selected = frame
            .selected
            .and_then(|unit| i32::try_from(unit).ok())
            .unwrap_or(-1);
        gl.uniform1i(uniforms.selected.as_ref(), selected);
        // The light in the camera's frame: right, up and back, from the pixel rays.
        let rays = pixel_rays(frame);
        let right = Vec3::from_slice(&rays[3..6]).normalize_or_zero();
        let up = Vec3::from_slice(&rays[6..9]).normalize_or_zero();
        let back = right.cross(up);
        let light = frame.light;
        gl.uniform3f(
            uniforms.light_view.as_ref(),
            light.dot(right),
            light.dot(up),
            light.dot(back),
        );
        gl.draw_arrays(Gl::POINTS, 0, units as i32);
    }

    /// Waits until the GPU has drawn everything asked so far (by reading one pixel
    /// back), so that a frame's time includes the drawing.
    pub fn finish(&self) {
        let mut pixel = [0u8; 4];
        // A failed read only shortens the measured time.
        let _ = self.gl.read_pixels_with_opt_u8_array(
            0,
            0,
            1,
            1,
            Gl::RGBA,
            Gl::UNSIGNED_BYTE,
            Some(&mut pixel),
        );
    }
}

/// The ray from the eye through the pixel at `(x, y)` (from the bottom left corner,
/// as `gl_FragCoord`) is `a + x dx + y dy`: `[a, dx, dy]`, world space, flattened.
fn pixel_rays(frame: &FrameView) -> [f32; 9] {
    let world_from_clip = frame.clip_from_world.inverse();
    let (width, height) = (frame.viewport.width, frame.viewport.height);
    let on_near = |x: f32, y: f32| {
        world_from_clip.project_point3(Vec3::new(
            x / width * 2.0 - 1.0,
            y / height * 2.0 - 1.0,
            -1.0,
        ))
    };
    let origin = on_near(0.0, 0.0);
    let a = origin - frame.eye;
    let dx = on_near(width, 0.0) - origin;
    let dy = on_near(0.0, height) - origin;
    let [dx, dy] = [dx / width, dy / height];
    [a.x, a.y, a.z, dx.x, dx.y, dx.z, dy.x, dy.y, dy.z]
}

/// Whether this browser's WebGL2 draws in software (SwiftShader, llvmpipe), asked of a
/// throw-away context.
fn software_renderer() -> bool {
    let Some(gl) = web_sys::window()
        .and_then(|window| window.document())
        .and_then(|document| document.create_element("canvas").ok())
        .and_then(|canvas| canvas.dyn_into::<HtmlCanvasElement>().ok())
        .and_then(|canvas| canvas.get_context("webgl2").ok().flatten())
        .and_then(|context| context.dyn_into::<Gl>().ok())
    else {
        return false;
    };
    // WEBGL_debug_renderer_info's UNMASKED_RENDERER_WEBGL.
    const UNMASKED_RENDERER: u32 = 0x9246;
    let renderer = match gl.get_extension("WEBGL_debug_renderer_info") {
        Ok(Some(_)) => gl.get_parameter(UNMASKED_RENDERER).ok(),
        _ => gl.get_parameter(Gl::RENDERER).ok(),
    }
    .and_then(|name| name.as_string())
    .unwrap_or_default()
    .to_ascii_lowercase();
    if let Ok(Some(lose)) = gl.get_extension("WEBGL_lose_context") {
        // Gives the context back at once rather than at the next garbage collection.
        let _ = js_sys::Reflect::get(&lose, &"loseContext".into())
            .ok()
            .and_then(|f| f.dyn_into::<js_sys::Function>().ok())
            .map(|f| f.call0(&lose));
    }
    ["swiftshader", "llvmpipe", "software"]
        .iter()
        .any(|name| renderer.contains(name))
}

/// A vertex array over line segments (pairs of points).
fn lines(gl: &Gl, points: &[[f32; 3]]) -> Result<Lines, String> {
    let vao = gl
        .create_vertex_array()
        .ok_or("cannot create a vertex array")?;
    gl.bind_vertex_array(Some(&vao));
    let buffer = gl.create_buffer().ok_or("cannot create a buffer")?;
    gl.bind_buffer(Gl::ARRAY_BUFFER, Some(&buffer));
    let array = js_sys::Float32Array::from(points.as_flattened());
    gl.buffer_data_with_array_buffer_view(Gl::ARRAY_BUFFER, &array, Gl::STATIC_DRAW);
    gl.enable_vertex_attrib_array(0);
    gl.vertex_attrib_pointer_with_i32(0, 3, Gl::FLOAT, false, 0, 0);
    gl.bind_vertex_array(None);
    Ok(Lines {
        vao,
        buffer,
        vertices: i32::try_from(points.len()).map_err(|_| "too many lines")?,
    })
}
