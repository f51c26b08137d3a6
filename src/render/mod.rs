//! Offscreen rendering of a [`GpuSolver`]'s cloth and its colliders.
//!
//! The [`Renderer`] borrows the host's device and queue (as the solver
//! does) and draws the cloth straight from the solver's buffers — positions
//! as the vertex buffer, the normals pass's output, the triangle indices —
//! so the mesh never visits the host. The ground and the spheres are two
//! small meshes made once and placed per instance.
//!
//! - [`Renderer::draw`] records into a render pass the host began (the
//!   pattern a game uses; see `examples/embed.rs`);
//! - [`Renderer::encode_frame`] begins that pass on a [`FrameTarget`];
//! - [`frames::render_frames`] runs a scene to numbered PNG files, reading
//!   frames back while the device computes the next ones.

pub mod camera;
pub mod frames;
mod mesh;
pub mod png_writer;
pub mod strain;

use wgpu::util::DeviceExt;

pub use camera::Camera;
pub use frames::{
    check_image, read_rgba, render_frames, render_scene, steps_per_frame, FrameOptions,
};

use crate::gpu::GpuSolver;
use crate::model::Model;
use crate::params::Params;

/// Colour format of the targets the renderer draws into. Not sRGB: the
/// shader gamma-encodes, so the clear colour's bytes are exactly
/// [`BACKGROUND`].
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Depth format of the targets.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
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

/// One collider instance: centre and scale, colour and checker flag
/// (`place` and `colour` of `vs_collider`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Instance {
    place: [f32; 4],
    colour: [f32; 4],
}

/// A unit mesh with its instances.
#[derive(Debug)]
struct Collider {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    instances: wgpu::Buffer,
    instance_count: u32,
}

/// Pipelines, the camera's uniform and the collider meshes of one scene.
#[derive(Debug)]
pub struct Renderer {
    queue: wgpu::Queue,
    shader: wgpu::ShaderModule,
    globals_layout: wgpu::BindGroupLayout,
    globals: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// The strain shown red in the strain view.
    strain_full_scale: f32,
    /// `Some`: the cloth is drawn coloured by strain.
    strain: Option<strain::StrainView>,
    cloth: wgpu::RenderPipeline,
    collider: wgpu::RenderPipeline,
    ground: Option<Collider>,
    spheres: Option<Collider>,
}

/// A colour texture and its depth buffer, the size of one frame.
#[derive(Debug)]
pub struct FrameTarget {
    /// The colour texture ([`COLOR_FORMAT`], `RENDER_ATTACHMENT | COPY_SRC`).
    pub color: wgpu::Texture,
    /// Its view.
    pub color_view: wgpu::TextureView,
    /// The depth buffer's view ([`DEPTH_FORMAT`]).
    pub depth_view: wgpu::TextureView,
}

impl FrameTarget {
    /// Makes a `width` × `height` target on `device`.
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> FrameTarget {
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
            COLOR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture(
            "wgcloth.render.depth",
            DEPTH_FORMAT,
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
    /// (placed around `camera`'s target), drawing with `camera`.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &Params,
        camera: &Camera,
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
        let cloth_buffers = [
            Some(vertex_layout(16, wgpu::VertexStepMode::Vertex, &positions)),
            Some(vertex_layout(16, wgpu::VertexStepMode::Vertex, &normals)),
        ];
        // A collider mesh (interleaved position, normal) and its instances.
        let mesh_attributes = [vec3_at(0, 0), vec3_at(1, 12)];
        let instance_attributes = wgpu::vertex_attr_array![2 => Float32x4, 3 => Float32x4];
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
                depth_stencil: Some(depth_state()),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(COLOR_FORMAT.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        // The cloth is seen from both sides: no culling.
        let cloth = pipeline("wgcloth.render.cloth", "vs_cloth", &cloth_buffers, None);
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
        let spheres: Vec<Instance> = params
            .spheres
            .iter()
            .map(|s| {
                let c = s.center.map(|v| v as f32);
                let r =
                    (s.radius as f32 - COLLIDER_INSET * camera.radius).max(0.5 * s.radius as f32);
                instance([c[0], c[1], c[2], r], SPHERE, 0.0)
            })
            .collect();
        let spheres = (!spheres.is_empty())
            .then(|| Collider::new(device, "spheres", &mesh::sphere(), &spheres));
        let renderer = Renderer {
            queue: queue.clone(),
            shader,
            globals_layout: layout,
            globals,
            strain_full_scale: strain::full_scale(params),
            strain: None,
            bind_group,
            cloth,
            collider,
            ground,
            spheres,
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
    /// at half of [`strain::full_scale`], red at and above it. Needs
    /// storage buffers in the vertex stage (every Vulkan, Metal and DX12
    /// device has them). [`Renderer::draw`] must then be given this
    /// `solver`.
    pub fn show_strain(&mut self, device: &wgpu::Device, model: &Model, solver: &GpuSolver) {
        self.strain = Some(strain::StrainView::new(
            device,
            &self.shader,
            &self.globals_layout,
            model,
            solver,
        ));
    }

    /// Records the cloth, the ground and the spheres into `pass`, a pass
    /// whose colour target is [`COLOR_FORMAT`] and depth target
    /// [`DEPTH_FORMAT`]. The cloth's normals must have been recorded
    /// (`GpuSolver::encode_normals`) since its last step.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, solver: &GpuSolver) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        if let Some(strain) = &self.strain {
            strain.draw(pass);
        } else {
            pass.set_pipeline(&self.cloth);
            pass.set_vertex_buffer(0, solver.positions_buffer().slice(..));
            pass.set_vertex_buffer(1, solver.normals_buffer().slice(..));
            pass.set_index_buffer(solver.index_buffer().slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..solver.index_count(), 0, 0..1);
        }
        pass.set_pipeline(&self.collider);
        for c in self.ground.iter().chain(&self.spheres) {
            pass.set_vertex_buffer(0, c.vertices.slice(..));
            pass.set_vertex_buffer(1, c.instances.slice(..));
            pass.set_index_buffer(c.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..c.index_count, 0, 0..c.instance_count);
        }
    }

    /// Records a render pass that clears `target` to [`BACKGROUND`] and
    /// draws the scene (see [`Renderer::draw`]).
    pub fn encode_frame(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        solver: &GpuSolver,
        target: &FrameTarget,
    ) {
        let mut pass = begin_pass(encoder, &target.color_view, &target.depth_view);
        self.draw(&mut pass, solver);
    }
}

/// Begins a render pass on `color` ([`COLOR_FORMAT`]) and `depth`
/// ([`DEPTH_FORMAT`]) that clears them to [`BACKGROUND`] and the far plane,
/// ready for [`Renderer::draw`]. A host's own views (e.g. a swap-chain
/// texture's, of the same formats) do as well as a [`FrameTarget`]'s.
pub fn begin_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    color: &wgpu::TextureView,
    depth: &wgpu::TextureView,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("wgcloth.render.pass"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(background()),
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

/// Depth test and write, nearer wins: every pipeline's.
fn depth_state() -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// [`BACKGROUND`] as a clear colour (the target is not sRGB, so the bytes
/// come out as given).
pub fn background() -> wgpu::Color {
    let c = BACKGROUND.map(|b| f64::from(b) / 255.0);
    wgpu::Color {
        r: c[0],
        g: c[1],
        b: c[2],
        a: c[3],
    }
}

/// The render shader's source (`shaders/render/mesh.wgsl`).
pub const SHADER: &str = include_str!("../../shaders/render/mesh.wgsl");

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
    }
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
                wgpu::BufferUsages::VERTEX,
            ),
            instance_count: instances.len() as u32,
        }
    }
}
