//! The WebGL2 renderer: thin glue between the plain maths ([`super::camera`],
//! [`super::scene`]) and the GPU.
//!
//! One draw for all balls, each a camera-facing quad on which the fragment shader
//! traces the exact sphere (a lit impostor: round at any distance for two triangles a
//! ball, with its true depth), Lambert plus ambient as [`super::scene::lit`]; one draw
//! of lines for the cables, from each ball up to its anchor; plain lines for the
//! ceiling grid and the floor reference.
//!
//! The per-ball data (centre and radius, colour) goes to the GPU as two small textures,
//! and the vertex shaders fetch their ball's texel by `gl_VertexID` ("vertex
//! pulling"): one non-instanced draw per kind, four vertices a ball through a fixed
//! index buffer. That is as cheap as instancing on a GPU, and several times cheaper on
//! SwiftShader, the software renderer of headless Chromium and of machines without a
//! usable GPU, which runs instanced draws one instance at a time. Per frame only the
//! two textures are updated, from buffers the caller keeps (nothing is allocated in
//! Rust per frame). Edges are smoothed by multisampling, except on a software
//! renderer, where it would cost several times the frame.
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
uniform lowp sampler2D u_colours;
uniform mat4 u_clip_from_world;
uniform vec3 u_eye;
uniform int u_selected;
out vec3 v_world;
flat out vec4 v_ball;
flat out vec3 v_colour;
flat out float v_selected;
const vec2 CORNERS[4] = vec2[4](vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(-1.0, 1.0), vec2(1.0, 1.0));
void main() {
    int ball = gl_VertexID / 4;
    int width = textureSize(u_balls, 0).x;
    ivec2 texel = ivec2(ball % width, ball / width);
    vec4 a_ball = texelFetch(u_balls, texel, 0);
    vec2 corner = CORNERS[gl_VertexID % 4];
    vec3 to_eye = u_eye - a_ball.xyz;
    float d = length(to_eye);
    float r = a_ball.w;
    v_ball = a_ball;
    v_colour = texelFetch(u_colours, texel, 0).rgb;
    v_selected = ball == u_selected ? 1.0 : 0.0;
    if (d <= r * 1.001) {
        // The eye is inside the ball: nothing to draw (outside the clip volume).
        v_world = a_ball.xyz;
        gl_Position = vec4(0.0, 0.0, 2.0, 1.0);
        return;
    }
    vec3 n = to_eye / d;
    vec3 side = abs(n.y) > 0.999 ? vec3(1.0, 0.0, 0.0) : normalize(cross(vec3(0.0, 1.0, 0.0), n));
    vec3 up = cross(n, side);
    // The cone from the eye touching the sphere cuts the plane through the centre
    // in a circle of this radius: the quad holds the whole silhouette.
    float h = r * d / sqrt(d * d - r * r) * 1.02;
    v_world = a_ball.xyz + (side * corner.x + up * corner.y) * h;
    gl_Position = u_clip_from_world * vec4(v_world, 1.0);
}
";

const BALL_FRAGMENT: &str = r"#version 300 es
precision highp float;
in vec3 v_world;
flat in vec4 v_ball;
flat in vec3 v_colour;
flat in float v_selected;
uniform mat4 u_clip_from_world;
uniform vec3 u_eye;
uniform vec3 u_light;
uniform float u_ambient;
uniform vec3 u_selected_colour;
out vec4 o_colour;
void main() {
    vec3 dir = normalize(v_world - u_eye);
    vec3 from_centre = u_eye - v_ball.xyz;
    float b = dot(from_centre, dir);
    float c = dot(from_centre, from_centre) - v_ball.w * v_ball.w;
    float disc = b * b - c;
    if (disc < 0.0) discard;
    vec3 hit = u_eye + dir * (-b - sqrt(disc));
    vec3 n = (hit - v_ball.xyz) / v_ball.w;
    vec3 rgb = v_colour * (u_ambient + (1.0 - u_ambient) * max(dot(n, u_light), 0.0));
    float rim = pow(1.0 - max(dot(n, -dir), 0.0), 2.0);
    rgb = mix(rgb, u_selected_colour, rim * v_selected);
    o_colour = vec4(rgb, 1.0);
    vec4 clip = u_clip_from_world * vec4(hit, 1.0);
    gl_FragDepth = clamp(clip.z / clip.w * 0.5 + 0.5, 0.0, 1.0);
}
";

const CABLE_VERTEX: &str = r"#version 300 es
uniform highp sampler2D u_balls;
uniform mat4 u_clip_from_world;
void main() {
    int ball = gl_VertexID / 2;
    int width = textureSize(u_balls, 0).x;
    vec4 a_ball = texelFetch(u_balls, ivec2(ball % width, ball / width), 0);
    vec3 anchor = vec3(a_ball.x, 0.0, a_ball.z);
    vec3 top_of_ball = a_ball.xyz + vec3(0.0, a_ball.w, 0.0);
    gl_Position = u_clip_from_world * vec4(gl_VertexID % 2 == 0 ? anchor : top_of_ball, 1.0);
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
    /// Per ball: centre `x, y, z` and radius, metres.
    pub balls: &'a [f32],
    /// Per ball: red, green, blue.
    pub colours: &'a [[u8; 3]],
    /// The ball to mark, if any.
    pub selected: Option<usize>,
}

/// A linked program and its uniforms.
#[derive(Debug)]
struct Program {
    program: WebGlProgram,
    clip_from_world: Option<WebGlUniformLocation>,
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
        let clip_from_world = gl.get_uniform_location(&program, "u_clip_from_world");
        Ok(Self {
            program,
            clip_from_world,
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

/// Balls per row of the per-ball textures (every WebGL2 allows 2048).
const TEXELS_PER_ROW: usize = 1024;

/// The per-ball textures, the JS-side arrays they are filled from, and the indices
/// of the balls' quads.
#[derive(Debug)]
struct BallTextures {
    /// Two triangles a ball: `4b, 4b+1, 4b+2` and `4b+2, 4b+1, 4b+3`.
    indices: WebGlBuffer,
    /// Centre and radius: RGBA32F.
    centres: WebGlTexture,
    /// Colour: RGB8.
    colours: WebGlTexture,
    centre_staging: js_sys::Float32Array,
    colour_staging: js_sys::Uint8Array,
    /// Texture width and height, texels.
    width: usize,
    height: usize,
}

impl BallTextures {
    fn new(gl: &Gl, units: usize) -> Result<Self, String> {
        let width = units.clamp(1, TEXELS_PER_ROW);
        let height = units.div_ceil(width).max(1);
        let texture = |format: u32| -> Result<WebGlTexture, String> {
            let texture = gl.create_texture().ok_or("cannot create a texture")?;
            gl.bind_texture(Gl::TEXTURE_2D, Some(&texture));
            gl.tex_storage_2d(Gl::TEXTURE_2D, 1, format, width as i32, height as i32);
            gl.tex_parameteri(Gl::TEXTURE_2D, Gl::TEXTURE_MIN_FILTER, Gl::NEAREST as i32);
            gl.tex_parameteri(Gl::TEXTURE_2D, Gl::TEXTURE_MAG_FILTER, Gl::NEAREST as i32);
            Ok(texture)
        };
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
            centres: texture(Gl::RGBA32F)?,
            colours: texture(Gl::RGB8)?,
            centre_staging: js_sys::Float32Array::new_with_length(texels * 4),
            colour_staging: js_sys::Uint8Array::new_with_length(texels * 3),
            width,
            height,
        })
    }

    fn capacity(&self) -> usize {
        self.width * self.height
    }

    fn delete(self, gl: &Gl) {
        gl.delete_buffer(Some(&self.indices));
        gl.delete_texture(Some(&self.centres));
        gl.delete_texture(Some(&self.colours));
    }

    /// Uploads the first `units` balls' centres and colours, whole rows at a time.
    fn upload(&self, gl: &Gl, units: usize, balls: &[f32], colours: &[[u8; 3]]) {
        let rows = units.div_ceil(self.width);
        let texels = (rows * self.width) as u32;
        self.centre_staging
            .subarray(0, (units * 4) as u32)
            .copy_from(&balls[..units * 4]);
        self.colour_staging
            .subarray(0, (units * 3) as u32)
            .copy_from(colours[..units].as_flattened());
        gl.pixel_storei(Gl::UNPACK_ALIGNMENT, 1);
        let centres: js_sys::Object = self.centre_staging.subarray(0, texels * 4).into();
        let colours: js_sys::Object = self.colour_staging.subarray(0, texels * 3).into();
        for (unit, texture, format, kind, pixels) in [
            (Gl::TEXTURE0, &self.centres, Gl::RGBA, Gl::FLOAT, &centres),
            (
                Gl::TEXTURE1,
                &self.colours,
                Gl::RGB,
                Gl::UNSIGNED_BYTE,
                &colours,
            ),
        ] {
            gl.active_texture(unit);
            gl.bind_texture(Gl::TEXTURE_2D, Some(texture));
            // A failed upload leaves last frame's balls; WebGL reports it on the console.
            let _ = gl
                .tex_sub_image_2d_with_i32_and_i32_and_u32_and_type_and_opt_array_buffer_view(
                    Gl::TEXTURE_2D,
                    0,
                    0,
                    0,
                    self.width as i32,
                    rows as i32,
                    format,
                    kind,
                    Some(pixels),
                );
        }
    }
}

/// The renderer of one canvas.
#[derive(Debug)]
pub struct GlView {
    gl: Gl,
    balls: Program,
    ball_uniforms: BallUniforms,
    cables: Program,
    lines: Program,
    /// The flat programs' colour (cables, lines).
    flat_colour: [Option<WebGlUniformLocation>; 2],
    /// Drawn with while vertices come from textures (holds the balls' index buffer).
    no_attributes: WebGlVertexArrayObject,
    textures: Option<BallTextures>,
    ceiling: Option<Lines>,
    floor: Option<Lines>,
}

/// The balls program's own uniforms.
#[derive(Debug)]
struct BallUniforms {
    eye: Option<WebGlUniformLocation>,
    light: Option<WebGlUniformLocation>,
    ambient: Option<WebGlUniformLocation>,
    selected: Option<WebGlUniformLocation>,
    selected_colour: Option<WebGlUniformLocation>,
}

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
            eye: balls.uniform(&gl, "u_eye"),
            light: balls.uniform(&gl, "u_light"),
            ambient: balls.uniform(&gl, "u_ambient"),
            selected: balls.uniform(&gl, "u_selected"),
            selected_colour: balls.uniform(&gl, "u_selected_colour"),
        };
        let cables = Program::new(&gl, CABLE_VERTEX, FLAT_FRAGMENT)?;
        let lines = Program::new(&gl, LINE_VERTEX, FLAT_FRAGMENT)?;
        let flat_colour = [
            cables.uniform(&gl, "u_colour"),
            lines.uniform(&gl, "u_colour"),
        ];
        // The samplers read texture units 0 (centres) and 1 (colours), for good.
        for (program, name, unit) in [
            (&balls, "u_balls", 0),
            (&balls, "u_colours", 1),
            (&cables, "u_balls", 0),
        ] {
            gl.use_program(Some(&program.program));
            gl.uniform1i(program.uniform(&gl, name).as_ref(), unit);
        }
        let no_attributes = gl
            .create_vertex_array()
            .ok_or("cannot create a vertex array")?;

        Ok(Self {
            gl,
            balls,
            ball_uniforms,
            cables,
            lines,
            flat_colour,
            no_attributes,
            textures: None,
            ceiling: None,
            floor: None,
        })
    }

    /// Prepares the textures and the grid for `scene` with `units` balls (once per
    /// show).
    pub fn set_scene(&mut self, scene: &Scene, units: usize) -> Result<(), String> {
        let gl = &self.gl;
        if self
            .textures
            .as_ref()
            .is_none_or(|textures| textures.capacity() < units)
        {
            if let Some(old) = self.textures.take() {
                old.delete(gl);
            }
            self.textures = Some(BallTextures::new(gl, units)?);
        }
        for old in [self.ceiling.take(), self.floor.take()]
            .into_iter()
            .flatten()
        {
            old.delete(gl);
        }
        let (ceiling, floor) = scene.grid_lines();
        self.ceiling = Some(lines(gl, &ceiling)?);
        self.floor = Some(lines(gl, &floor)?);
        Ok(())
    }

    /// Draws a frame.
    pub fn draw(&self, frame: &FrameView) {
        let gl = &self.gl;
        let units = (frame.balls.len() / 4)
            .min(frame.colours.len())
            .min(self.textures.as_ref().map_or(0, BallTextures::capacity));
        gl.viewport(
            0,
            0,
            frame.viewport.width as i32,
            frame.viewport.height as i32,
        );
        let [r, g, b] = BACKGROUND;
        gl.clear_color(r, g, b, 1.0);
        gl.enable(Gl::DEPTH_TEST);
        gl.clear(Gl::COLOR_BUFFER_BIT | Gl::DEPTH_BUFFER_BIT);

        let matrix = &frame.clip_from_world;
        self.lines.use_with(gl, matrix);
        for (lines, colour) in [(&self.ceiling, CEILING_COLOUR), (&self.floor, FLOOR_COLOUR)] {
            if let Some(lines) = lines {
                gl.uniform3fv_with_f32_array(self.flat_colour[1].as_ref(), &colour);
                gl.bind_vertex_array(Some(&lines.vao));
                gl.draw_arrays(Gl::LINES, 0, lines.vertices);
            }
        }
        let Some(textures) = self.textures.as_ref().filter(|_| units > 0) else {
            gl.bind_vertex_array(None);
            return;
        };
        textures.upload(gl, units, frame.balls, frame.colours);
        gl.bind_vertex_array(Some(&self.no_attributes));
        gl.bind_buffer(Gl::ELEMENT_ARRAY_BUFFER, Some(&textures.indices));

        self.cables.use_with(gl, matrix);
        gl.uniform3fv_with_f32_array(self.flat_colour[0].as_ref(), &CABLE_COLOUR);
        gl.draw_arrays(Gl::LINES, 0, (units * 2) as i32);

        self.balls.use_with(gl, matrix);
        let uniforms = &self.ball_uniforms;
        gl.uniform3fv_with_f32_array(uniforms.eye.as_ref(), &frame.eye.to_array());
        gl.uniform3fv_with_f32_array(uniforms.light.as_ref(), &frame.light.to_array());
        gl.uniform1f(uniforms.ambient.as_ref(), AMBIENT);
        let selected = frame
            .selected
            .and_then(|unit| i32::try_from(unit).ok())
            .unwrap_or(-1);
        gl.uniform1i(uniforms.selected.as_ref(), selected);
        gl.uniform3fv_with_f32_array(uniforms.selected_colour.as_ref(), &SELECTED_COLOUR);
        gl.draw_elements_with_i32(Gl::TRIANGLES, (units * 6) as i32, Gl::UNSIGNED_INT, 0);
        gl.bind_vertex_array(None);
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
