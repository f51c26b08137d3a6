//! Offscreen rendering of a [`GpuSolver`]'s cloth and its colliders.
//!
//! The [`Renderer`] borrows the host's device and queue (as the solver
//! does) and draws the cloth straight from the solver's buffers — positions
//! as the vertex buffer, the normals pass's output, the triangle indices —
//! so the mesh never visits the host. The ground and the spheres are two
//! small meshes made once and placed per instance.
//!
//! - [`Renderer::draw`] records into a render pass the host began (the
//!   pattern a game uses; see `examples/embed.rs`), on targets of the
//!   host's formats ([`RendererFormats`], given to
//!   [`Renderer::with_formats`]);
//! - [`Renderer::encode_frame`] begins that pass on a [`FrameTarget`];
//! - [`render_frames`] runs a scene to numbered PNG files, reading
//!   frames back while the device computes the next ones.

mod camera;
mod frames;
mod mesh;
mod png_writer;
mod strain;

use wgpu::util::DeviceExt;

pub use camera::Camera;
pub use frames::{
    check_image, read_rgba, render_frames, render_scene, render_scene_on_path,
    render_scene_with_kernels, steps_per_frame, FrameOptions, MAX_STEPS_PER_FRAME, STAGING_BUFFERS,
};
pub use png_writer::{existing_frames, frame_name, is_frame_name, remove_frames, write_png, Frame};

use crate::error::{Error, Result};
use crate::gpu::{guarded, DrawRange, GpuRenderMesh, GpuSolver, SkinLayout};
use crate::kernel_config::{MAX_CAPSULES, MAX_SPHERES};
use crate::model::Model;
use crate::params::{Capsule, Params, Sphere};
use crate::render_mesh::Embedding;
use std::ops::Range;
use std::sync::atomic::{AtomicU32, Ordering};

/// Default colour format of the targets the renderer draws into, and the
/// one the PNG frames are read from. Not sRGB: the shader gamma-encodes,
/// so the clear colour's bytes are exactly [`BACKGROUND`].
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Default depth format of the targets.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The formats of the colour and depth targets a [`Renderer`] draws into:
/// its pipelines are built for these, and a render pass given to
/// [`Renderer::draw`] must have attachments of exactly these formats.
///
/// The picture is the same on any colour format. The shader computes the
/// gamma-encoded colour the PNG frames hold (their bytes are those values
/// on an `Rgba8Unorm` target); on an `*Srgb` target, whose hardware
/// sRGB-encodes what the shader writes, it writes instead the linear value
/// whose sRGB encoding is that colour (the `SRGB_TARGET` override constant
/// of `shaders/render/mesh.wgsl`), and the clear colour is decoded the
/// same way ([`background_for`]). A viewer sees the same colours either
/// way, to within the rounding of the 8-bit encode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RendererFormats {
    /// Colour target: any format with a colour aspect and a float sample
    /// type the device can render to (e.g. a swap chain's
    /// `Bgra8UnormSrgb`); alpha is written as 1.
    pub color: wgpu::TextureFormat,
    /// Depth target: any format with a depth aspect (e.g. `Depth24Plus`).
    pub depth: wgpu::TextureFormat,
}

impl Default for RendererFormats {
    /// [`COLOR_FORMAT`] and [`DEPTH_FORMAT`]: what the PNG frames use.
    fn default() -> RendererFormats {
        RendererFormats {
            color: COLOR_FORMAT,
            depth: DEPTH_FORMAT,
        }
    }
}

impl RendererFormats {
    /// Refuses formats no pipeline of the renderer can draw into: a colour
    /// format without a colour aspect or with an integer sample type (the
    /// fragment shader writes `vec4<f32>`), a depth format without a depth
    /// aspect. What the device supports is checked when the pipelines are
    /// built.
    fn check(self, device: &wgpu::Device) -> Result<()> {
        let float = matches!(
            self.color.sample_type(None, Some(device.features())),
            Some(wgpu::TextureSampleType::Float { .. })
        );
        if !(self.color.has_color_aspect() && float) {
            return Err(Error::InvalidParameter {
                key: "RendererFormats::color".into(),
                allowed: "a colour format with a float sample type".into(),
                got: format!("{:?}", self.color),
            });
        }
        if !self.depth.has_depth_aspect() {
            return Err(Error::InvalidParameter {
                key: "RendererFormats::depth".into(),
                allowed: "a format with a depth aspect".into(),
                got: format!("{:?}", self.depth),
            });
        }
        Ok(())
    }

    /// The render shader's override constants for this colour target.
    fn constants(self) -> [(&'static str, f64); 1] {
        [("SRGB_TARGET", if self.color.is_srgb() { 1.0 } else { 0.0 })]
    }
}

/// The background (clear) colour, RGBA bytes as they land in the image.
pub const BACKGROUND: [u8; 4] = [30, 34, 44, 255];

/// Cloth front colour (linear RGB): a warm red.
const CLOTH_FRONT: [f32; 3] = [0.75, 0.12, 0.08];
/// Cloth back colour: a paler orange, so a fold shows which side is up.
const CLOTH_BACK: [f32; 3] = [0.85, 0.45, 0.15];
/// Ground colour (checkered by the shader).
const GROUND: [f32; 3] = [0.45, 0.45, 0.42];
/// Sphere colour.
const SPHERE: [f32; 3] = [0.25, 0.40, 0.70];
/// Mesh collider colour: a warm wood, apart from the blue round bodies.
const BODY: [f32; 3] = [0.55, 0.38, 0.24];
/// Direction towards the light (normalised in `Renderer::new`): from above,
/// a little to the front-right.
const LIGHT: [f32; 3] = [0.4, 1.0, 0.6];
/// Colliders are drawn this much smaller than they collide [fraction of
/// the camera-fitting radius]: the cloth resting on them keeps its
/// particles on their surface, but its flat triangles cut chords below it,
/// and a collider drawn at full size shows through them in spots.
const COLLIDER_INSET: f32 = 0.01;
/// Half-width of the ground quad, in camera-fitting radii: it reaches past
/// the edges of the image at the bottom, and the sky shows at the top.
const GROUND_RADII: f32 = 3.0;

/// Twin of `Globals` in `shaders/render/mesh.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    light: [f32; 4],
    cloth_front: [f32; 4],
    cloth_back: [f32; 4],
    strain: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<Globals>() == 128);

/// Size of the render shader's `Globals` uniform on the host \[bytes\] (the
/// shader tests check the WGSL struct has the same).
pub const GLOBALS_BYTES: u32 = std::mem::size_of::<Globals>() as u32;

/// One collider instance: centre and scale, colour and checker flag, half
/// a capsule's segment (`place`, `colour` and `axis` of `vs_collider`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Instance {
    place: [f32; 4],
    colour: [f32; 4],
    axis: [f32; 4],
}

/// The most round colliders (spheres and capsules) a renderer draws: all
/// the GPU solver takes.
const MAX_ROUND: usize = MAX_SPHERES + MAX_CAPSULES;

/// A unit mesh with its instances.
#[derive(Debug)]
struct Collider {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    instances: wgpu::Buffer,
    /// Instances drawn (the round colliders change it per frame).
    instance_count: AtomicU32,
}

/// Pipelines, the camera's uniform and the collider meshes of one scene.
#[derive(Debug)]
pub struct Renderer {
    queue: wgpu::Queue,
    formats: RendererFormats,
    shader: wgpu::ShaderModule,
    globals_layout: wgpu::BindGroupLayout,
    globals: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// The strain shown red in the strain view.
    strain_full_scale: f32,
    /// `Some`: the cloth is drawn coloured by strain.
    strain: Option<strain::StrainView>,
    cloth: wgpu::RenderPipeline,
    /// A render mesh's vertex buffer ([`SkinLayout::POSITION_NORMAL`]).
    render_mesh: wgpu::RenderPipeline,
    /// Drawn in place of the cloth when there are any.
    render_meshes: Vec<GpuRenderMesh>,
    /// The cloths' tints (`vs_cloth`'s instance slot): entry 0 the
    /// globals' colours, then one per cloth of a world
    /// ([`Renderer::set_cloth_colors`]).
    tints: wgpu::Buffer,
    /// Each cloth's index range and its tint's entry; empty: the whole
    /// cloth in the globals' colours.
    pieces: Vec<(Range<u32>, u32)>,
    collider: wgpu::RenderPipeline,
    ground: Option<Collider>,
    /// Spheres and capsules, all drawn with the capsule mesh (a sphere is
    /// a capsule without length); [`Renderer::set_colliders`] moves them.
    round: Collider,
    /// How much smaller than they collide colliders are drawn \[m\]
    /// (`COLLIDER_INSET` of the camera's radius).
    inset: f32,
    /// Mesh colliders, each drawn where the scene sets it.
    bodies: Vec<Collider>,
}

/// A colour texture and its depth buffer, the size of one frame.
#[derive(Debug)]
pub struct FrameTarget {
    /// The colour texture ([`COLOR_FORMAT`] unless made by
    /// [`FrameTarget::with_formats`]; `RENDER_ATTACHMENT | COPY_SRC`).
    pub color: wgpu::Texture,
    /// Its view.
    pub color_view: wgpu::TextureView,
    /// The depth buffer's view ([`DEPTH_FORMAT`] unless made by
    /// [`FrameTarget::with_formats`]).
    pub depth_view: wgpu::TextureView,
}

impl FrameTarget {
    /// Makes a `width` × `height` target \[pixels\] on `device` of the
    /// default formats ([`RendererFormats::default`]).
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> FrameTarget {
        FrameTarget::with_formats(device, width, height, RendererFormats::default())
    }

    /// Makes a `width` × `height` target \[pixels\] on `device` of
    /// `formats`, for a renderer made with the same.
    pub fn with_formats(
        device: &wgpu::Device,
        width: u32,
        height: u32,
        formats: RendererFormats,
    ) -> FrameTarget {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let texture = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let color = texture(
            "wgcloth.render.color",
            formats.color,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture(
            "wgcloth.render.depth",
            formats.depth,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        FrameTarget {
            color_view: color.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color,
        }
    }
}

impl Renderer {
    /// Builds the pipelines and the meshes of `params`' ground and spheres
    /// (placed around `camera`'s target), drawing with `camera` into
    /// targets of the default formats ([`COLOR_FORMAT`], [`DEPTH_FORMAT`]).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &Params,
        camera: &Camera,
    ) -> Renderer {
        Renderer::build(device, queue, params, camera, RendererFormats::default())
    }

    /// As [`Renderer::new`], drawing into targets of the host's `formats`
    /// (e.g. its swap chain's colour format and its depth buffer's). A
    /// format no pipeline can draw into is an [`Error::InvalidParameter`]
    /// naming it; one the device cannot render to an [`Error::Gpu`].
    pub fn with_formats(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &Params,
        camera: &Camera,
        formats: RendererFormats,
    ) -> Result<Renderer> {
        formats.check(device)?;
        guarded(device, "building the renderer", None, || {
            Ok(Renderer::build(device, queue, params, camera, formats))
        })
    }

    /// The formats this renderer draws into.
    pub fn formats(&self) -> RendererFormats {
        self.formats
    }

    fn build(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &Params,
        camera: &Camera,
        formats: RendererFormats,
    ) -> Renderer {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("wgcloth.render.mesh"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wgcloth.render.globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wgcloth.render.globals"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wgcloth.render.globals"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wgcloth.render"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let vec3_at = |location, offset| wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset,
            shader_location: location,
        };
        // The solver's positions and normals: one vec4 per particle each.
        let positions = [vec3_at(0, 0)];
        let normals = [vec3_at(1, 0)];
        let tint = [wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x4,
            offset: 0,
            shader_location: 2,
        }];
        let tint_buffer = vertex_layout(16, wgpu::VertexStepMode::Instance, &tint);
        let cloth_buffers = [
            Some(vertex_layout(16, wgpu::VertexStepMode::Vertex, &positions)),
            Some(vertex_layout(16, wgpu::VertexStepMode::Vertex, &normals)),
            Some(tint_buffer.clone()),
        ];
        // A collider mesh (interleaved position, normal) and its instances.
        let mesh_attributes = [vec3_at(0, 0), vec3_at(1, 12)];
        let instance_attributes =
            wgpu::vertex_attr_array![2 => Float32x4, 3 => Float32x4, 4 => Float32x4];
        let collider_buffers = [
            Some(vertex_layout(
                24,
                wgpu::VertexStepMode::Vertex,
                &mesh_attributes,
            )),
            Some(vertex_layout(
                std::mem::size_of::<Instance>() as u64,
                wgpu::VertexStepMode::Instance,
                &instance_attributes,
            )),
        ];
        let constants = formats.constants();
        let targets = [Some(formats.color.into())];
        let pipeline = |label, entry, buffers: &[Option<wgpu::VertexBufferLayout<'_>>], cull| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: cull,
                    ..Default::default()
                },
                depth_stencil: Some(depth_state(formats.depth)),
                multisample: Default::default(),
                fragment: Some(fragment_state(&shader, &constants, &targets)),
                multiview_mask: None,
                cache: None,
            })
        };
        // The cloth is seen from both sides: no culling.
        let cloth = pipeline("wgcloth.render.cloth", "vs_cloth", &cloth_buffers, None);
        // A render mesh's vertices: position and normal interleaved, as a
        // collider mesh's; seen from both sides too.
        let render_mesh_buffers = [
            Some(vertex_layout(
                24,
                wgpu::VertexStepMode::Vertex,
                &mesh_attributes,
            )),
            Some(tint_buffer),
        ];
        let render_mesh = pipeline(
            "wgcloth.render.render_mesh",
            "vs_cloth",
            &render_mesh_buffers,
            None,
        );
        let collider = pipeline(
            "wgcloth.render.collider",
            "vs_collider",
            &collider_buffers,
            Some(wgpu::Face::Back),
        );
        let ground = params.ground.map(|g| {
            let place = [
                camera.target[0],
                g.height as f32 - COLLIDER_INSET * camera.radius,
                camera.target[2],
                GROUND_RADII * camera.radius,
            ];
            Collider::new(
                device,
                "ground",
                &mesh::quad(),
                &[instance(place, GROUND, 1.0)],
            )
        });
        let inset = COLLIDER_INSET * camera.radius;
        let mut round = [Instance::default(); MAX_ROUND];
        let count = round_instances(&params.spheres, &params.capsules, inset, &mut round);
        let round = Collider::new(device, "round", &mesh::capsule(), &round);
        round.instance_count.store(count, Ordering::Relaxed);
        let bodies = params
            .mesh_colliders
            .iter()
            .map(|m| {
                let (body, factor) = mesh::body(m);
                Collider::new(
                    device,
                    "body",
                    &body,
                    &[instance([0.0, 0.0, 0.0, factor], BODY, 0.0)],
                )
            })
            .collect();
        let renderer = Renderer {
            queue: queue.clone(),
            formats,
            shader,
            globals_layout: layout,
            globals,
            strain_full_scale: strain::full_scale(params),
            strain: None,
            bind_group,
            cloth,
            render_mesh,
            render_meshes: Vec::new(),
            tints: tint_buffer_of(device, &[[0.0; 4]]),
            pieces: Vec::new(),
            collider,
            ground,
            round,
            inset,
            bodies,
        };
        renderer.set_camera(camera);
        renderer
    }

    /// Draws with `camera` from the next submit on.
    pub fn set_camera(&self, camera: &Camera) {
        let l = LIGHT;
        let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
        let globals = Globals {
            view_proj: camera.view_proj,
            light: [l[0] / n, l[1] / n, l[2] / n, 0.0],
            cloth_front: [CLOTH_FRONT[0], CLOTH_FRONT[1], CLOTH_FRONT[2], 1.0],
            cloth_back: [CLOTH_BACK[0], CLOTH_BACK[1], CLOTH_BACK[2], 1.0],
            strain: [self.strain_full_scale, 0.0, 0.0, 0.0],
        };
        self.queue
            .write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));
    }

    /// From now on, draws `solver`'s cloth (made from `model`) coloured per
    /// triangle by its largest edge strain (l − L) / L: blue at ≤ 0, green
    /// at half of `strain::full_scale`, red at and above it. Needs
    /// storage buffers in the vertex stage (every Vulkan, Metal and DX12
    /// device has them). [`Renderer::draw`] must then be given this
    /// `solver`.
    pub fn show_strain(&mut self, device: &wgpu::Device, model: &Model, solver: &GpuSolver) {
        self.strain = Some(strain::StrainView::new(
            device,
            &self.shader,
            &self.globals_layout,
            self.formats,
            model,
            solver,
        ));
    }

    /// Draws each cloth of the world `model` (a scene's:
    /// [`Scene::model`](crate::Scene::model)) in its colour from now on:
    /// `colors[c]` for cloth `c`, sRGB components in 0..=1 as they land in
    /// the picture (a scene's `color`), or `None` for the renderer's own
    /// colours. Cloths past the end of `colors` take the renderer's.
    pub fn set_cloth_colors(
        &mut self,
        device: &wgpu::Device,
        model: &Model,
        colors: &[Option<[f64; 3]>],
    ) {
        let starts = &model.cloth_starts;
        let mut tints = vec![[0.0f32; 4]];
        let mut pieces = Vec::with_capacity(starts.len());
        let mut first = 0usize;
        for c in 0..starts.len() {
            // A world's triangles come cloth by cloth.
            let end = starts.get(c + 1).map_or(model.triangles.len(), |&next| {
                model.triangles.partition_point(|t| t[0] < next)
            });
            let tint = match colors.get(c).copied().flatten() {
                Some(rgb) => {
                    let [r, g, b] = rgb.map(|v| srgb_to_linear(v) as f32);
                    tints.push([r, g, b, 1.0]);
                    tints.len() as u32 - 1
                }
                None => 0,
            };
            pieces.push((3 * first as u32..3 * end as u32, tint));
            first = end;
        }
        self.tints = tint_buffer_of(device, &tints);
        self.pieces = pieces;
    }

    /// Draws `spheres` and `capsules` where they are given from the next
    /// submit on (at most [`MAX_SPHERES`] and [`MAX_CAPSULES`]; more are
    /// left out): a host moving colliders passes where they are each
    /// frame, e.g. [`GpuSolver::colliders`].
    pub fn set_colliders(&self, spheres: &[Sphere], capsules: &[Capsule]) {
        let mut round = [Instance::default(); MAX_ROUND];
        let count = round_instances(spheres, capsules, self.inset, &mut round);
        self.queue.write_buffer(
            &self.round.instances,
            0,
            bytemuck::cast_slice(&round[..count as usize]),
        );
        self.round.instance_count.store(count, Ordering::Relaxed);
    }

    /// Draws `meshes` in place of the cloths they follow
    /// ([`GpuRenderMesh::follows`]) from now on (none: the cloths
    /// themselves), each written by its `skin` pass
    /// ([`Renderer::encode_render_meshes`]). Refused: a mesh whose vertex
    /// buffer is not [`SkinLayout::POSITION_NORMAL`].
    pub fn set_render_meshes(&mut self, meshes: Vec<GpuRenderMesh>) -> Result<()> {
        if let Some(m) = meshes
            .iter()
            .find(|m| m.layout() != SkinLayout::POSITION_NORMAL)
        {
            return Err(Error::InvalidParameter {
                key: "Renderer::set_render_meshes".into(),
                allowed: "render meshes of SkinLayout::POSITION_NORMAL".into(),
                got: format!("{:?}", m.layout()),
            });
        }
        self.render_meshes = meshes;
        Ok(())
    }

    /// Draws the render meshes of `embeddings` (a scene's:
    /// [`Scene::embeddings`](crate::Scene::embeddings)) on `solver`'s cloth
    /// in place of it from now on, each made with
    /// [`SkinLayout::POSITION_NORMAL`] (see [`Renderer::set_render_meshes`]).
    pub fn set_embeddings(&mut self, solver: &GpuSolver, embeddings: &[Embedding]) -> Result<()> {
        let meshes = embeddings
            .iter()
            .map(|e| GpuRenderMesh::new(solver, e, SkinLayout::POSITION_NORMAL))
            .collect::<Result<Vec<_>>>()?;
        self.set_render_meshes(meshes)
    }

    /// Records the `skin` pass of each render mesh
    /// ([`Renderer::set_render_meshes`]) into `encoder`, from its cloth,
    /// whose normals must have been recorded since its last step; before
    /// the render pass that draws them.
    pub fn encode_render_meshes(&self, encoder: &mut wgpu::CommandEncoder) {
        for m in &self.render_meshes {
            m.encode(encoder);
        }
    }

    /// Records the cloth (or its render meshes, whose `skin` passes
    /// [`Renderer::encode_render_meshes`] recorded), the ground, the
    /// spheres and the capsules into `pass`, a pass
    /// whose colour and depth targets have this renderer's
    /// [`formats`](Renderer::formats). The cloth's normals must have been recorded
    /// (`GpuSolver::encode_normals`) since its last step.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, solver: &GpuSolver) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        if let Some(strain) = &self.strain {
            strain.draw(pass);
        } else {
            self.draw_render_meshes(pass);
            let range = solver.draw_range();
            if self.pieces.is_empty() {
                if self.render_meshes.is_empty() {
                    self.draw_range(pass, &range);
                }
            } else {
                // The cloths no render mesh is drawn in place of.
                let replaced = |c: usize| {
                    self.render_meshes
                        .iter()
                        .any(|m| m.follows().is_none_or(|f| f == c))
                };
                let shown = (0..self.pieces.len())
                    .filter(|&c| !replaced(c))
                    .map(|c| self.pieces[c].clone());
                self.draw_pieces(pass, &range, shown);
            }
        }
        self.draw_colliders(pass);
    }

    /// Records the render meshes, each in the colour of the cloth it
    /// follows.
    fn draw_render_meshes(&self, pass: &mut wgpu::RenderPass<'_>) {
        if self.render_meshes.is_empty() {
            return;
        }
        pass.set_pipeline(&self.render_mesh);
        pass.set_vertex_buffer(1, self.tints.slice(..));
        for m in &self.render_meshes {
            let tint = m
                .follows()
                .and_then(|c| self.pieces.get(c))
                .map_or(0, |p| p.1);
            pass.set_vertex_buffer(0, m.vertex_buffer().slice(..));
            pass.set_index_buffer(m.index_buffer().slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..m.index_count(), 0, tint..tint + 1);
        }
    }

    /// Records one cloth of a [`GpuBatch`](crate::gpu::GpuBatch) into
    /// `pass`, straight from the batch's buffers (its
    /// [`draw_range`](crate::gpu::GpuBatch::draw_range)); shaded, not by
    /// strain. The batch's normals must have been recorded
    /// ([`GpuBatch::encode_normals`](crate::gpu::GpuBatch::encode_normals))
    /// since its last step. Draws no collider: see
    /// [`Renderer::draw_colliders`], once per pass.
    pub fn draw_batch_cloth(&self, pass: &mut wgpu::RenderPass<'_>, range: &DrawRange<'_>) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        self.draw_range(pass, range);
    }

    /// Records the ground, the spheres and the capsules into `pass` (what
    /// [`Renderer::draw`] adds to the cloth).
    pub fn draw_colliders(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_pipeline(&self.collider);
        for c in self.ground.iter().chain([&self.round]).chain(&self.bodies) {
            let instances = c.instance_count.load(Ordering::Relaxed);
            if instances == 0 {
                continue;
            }
            pass.set_vertex_buffer(0, c.vertices.slice(..));
            pass.set_vertex_buffer(1, c.instances.slice(..));
            pass.set_index_buffer(c.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..c.index_count, 0, 0..instances);
        }
    }

    /// A shaded cloth where `range` places it: its position and normal
    /// vertex buffers, its indices relative to its base vertex.
    fn draw_range(&self, pass: &mut wgpu::RenderPass<'_>, range: &DrawRange<'_>) {
        self.draw_pieces(pass, range, [(range.indices.clone(), 0)]);
    }

    fn draw_pieces(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        range: &DrawRange<'_>,
        pieces: impl IntoIterator<Item = (Range<u32>, u32)>,
    ) {
        pass.set_pipeline(&self.cloth);
        pass.set_vertex_buffer(0, range.positions.slice(..));
        pass.set_vertex_buffer(1, range.normals.slice(..));
        pass.set_vertex_buffer(2, self.tints.slice(..));
        pass.set_index_buffer(range.index_buffer.slice(..), wgpu::IndexFormat::Uint32);
        for (indices, tint) in pieces {
            pass.draw_indexed(indices, range.base_vertex, tint..tint + 1);
        }
    }

    /// Records the render meshes' `skin` passes
    /// ([`Renderer::encode_render_meshes`]), then a render pass that clears
    /// `target` to [`BACKGROUND`] and draws the scene (see
    /// [`Renderer::draw`]).
    pub fn encode_frame(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        solver: &GpuSolver,
        target: &FrameTarget,
    ) {
        self.encode_render_meshes(encoder);
        let mut pass = self.begin_pass(encoder, &target.color_view, &target.depth_view);
        self.draw(&mut pass, solver);
    }

    /// Begins a render pass on `color` and `depth`, views of this
    /// renderer's [`formats`](Renderer::formats), that clears them to
    /// [`BACKGROUND`] (as [`background_for`] the colour format) and the far
    /// plane, ready for [`Renderer::draw`]. A host's own views (e.g. a
    /// swap-chain texture's) do as well as a [`FrameTarget`]'s.
    pub fn begin_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
    ) -> wgpu::RenderPass<'e> {
        clearing_pass(encoder, color, depth, background_for(self.formats.color))
    }
}

/// Begins a render pass on `color` ([`COLOR_FORMAT`]) and `depth`
/// ([`DEPTH_FORMAT`]) that clears them to [`BACKGROUND`] and the far plane,
/// ready for a [`Renderer`] of the default formats. For other formats,
/// [`Renderer::begin_pass`].
pub fn begin_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    color: &wgpu::TextureView,
    depth: &wgpu::TextureView,
) -> wgpu::RenderPass<'e> {
    clearing_pass(encoder, color, depth, background())
}

/// A render pass on `color` and `depth` that clears them to `clear` and
/// the far plane.
fn clearing_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    color: &wgpu::TextureView,
    depth: &wgpu::TextureView,
    clear: wgpu::Color,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("wgcloth.render.pass"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(clear),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Discard,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// The fragment stage of every pipeline: `fs_main` with `constants`
/// (`RendererFormats::constants`' for the colour target) into `targets`.
fn fragment_state<'a>(
    shader: &'a wgpu::ShaderModule,
    constants: &'a [(&'static str, f64)],
    targets: &'a [Option<wgpu::ColorTargetState>],
) -> wgpu::FragmentState<'a> {
    wgpu::FragmentState {
        module: shader,
        entry_point: Some("fs_main"),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        },
        targets,
    }
}

/// Depth test and write into a `format` target, nearer wins: every
/// pipeline's.
fn depth_state(format: wgpu::TextureFormat) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// [`BACKGROUND`] as a clear colour for a [`COLOR_FORMAT`] target (not
/// sRGB, so the bytes come out as given).
pub fn background() -> wgpu::Color {
    background_for(COLOR_FORMAT)
}

/// [`BACKGROUND`] as a clear colour for a `format` target: the bytes as
/// given on a linear format; on an `*Srgb` one, whose hardware sRGB-encodes
/// the clear colour, their sRGB decoding, so that the stored bytes are
/// [`BACKGROUND`] again (to within rounding).
pub fn background_for(format: wgpu::TextureFormat) -> wgpu::Color {
    let c = BACKGROUND.map(|b| f64::from(b) / 255.0);
    let rgb = |v: f64| {
        if format.is_srgb() {
            srgb_to_linear(v)
        } else {
            v
        }
    };
    wgpu::Color {
        r: rgb(c[0]),
        g: rgb(c[1]),
        b: rgb(c[2]),
        a: c[3],
    }
}

/// The sRGB transfer function's inverse (IEC 61966-2-1): an encoded value
/// in \[0, 1\] to linear; twin of `srgb_to_linear` in `mesh.wgsl`.
fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The render shader's source (`shaders/render/mesh.wgsl`).
pub const SHADER: &str = include_str!("../../shaders/render/mesh.wgsl");

/// A vertex buffer of tints (`vs_cloth`'s instance slot).
fn tint_buffer_of(device: &wgpu::Device, tints: &[[f32; 4]]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("wgcloth.render.tints"),
        contents: bytemuck::cast_slice(tints),
        usage: wgpu::BufferUsages::VERTEX,
    })
}

fn vertex_layout<'a>(
    stride: u64,
    step_mode: wgpu::VertexStepMode,
    attributes: &'a [wgpu::VertexAttribute],
) -> wgpu::VertexBufferLayout<'a> {
    wgpu::VertexBufferLayout {
        array_stride: stride,
        step_mode,
        attributes,
    }
}

fn instance(place: [f32; 4], colour: [f32; 3], checker: f32) -> Instance {
    Instance {
        place,
        colour: [colour[0], colour[1], colour[2], checker],
        axis: [0.0; 4],
    }
}

/// Writes the instances of `spheres` and then `capsules` into `out` (as
/// many as fit), each drawn `inset` \[m\] thinner than it collides (at
/// least half its radius); returns how many.
fn round_instances(
    spheres: &[Sphere],
    capsules: &[Capsule],
    inset: f32,
    out: &mut [Instance],
) -> u32 {
    let drawn = |r: f64| (r as f32 - inset).max(0.5 * r as f32);
    let balls = spheres.iter().map(|s| (s.center, s.center, s.radius));
    let sticks = capsules.iter().map(|c| (c.a, c.b, c.radius));
    let mut count = 0;
    for (slot, (a, b, r)) in out.iter_mut().zip(balls.chain(sticks)) {
        let (centre, half) = (((a + b) * 0.5).as_vec3(), ((b - a) * 0.5).as_vec3());
        *slot = Instance {
            axis: half.extend(0.0).to_array(),
            ..instance(centre.extend(drawn(r)).to_array(), SPHERE, 0.0)
        };
        count += 1;
    }
    count
}

impl Collider {
    fn new(
        device: &wgpu::Device,
        name: &str,
        mesh: &mesh::Mesh,
        instances: &[Instance],
    ) -> Collider {
        let buffer = |what: &str, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(&format!("wgcloth.render.{name}.{what}")),
                contents,
                usage,
            })
        };
        Collider {
            vertices: buffer(
                "vertices",
                bytemuck::cast_slice(&mesh.vertices),
                wgpu::BufferUsages::VERTEX,
            ),
            indices: buffer(
                "indices",
                bytemuck::cast_slice(&mesh.indices),
                wgpu::BufferUsages::INDEX,
            ),
            index_count: mesh.indices.len() as u32,
            instances: buffer(
                "instances",
                bytemuck::cast_slice(instances),
                wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            ),
            instance_count: AtomicU32::new(instances.len() as u32),
        }
    }
}
