//! The strain view: the cloth coloured per triangle by its largest edge
//! strain, blue (≤ 0) → green → red (at and above a full-scale strain).
//!
//! The solver's index buffer is an index buffer only, so the view keeps
//! its own copies of the triangles and the rest positions as storage
//! buffers, reads the solver's positions and normals as storage too, and
//! draws three vertices per triangle without an index buffer: each vertex
//! then sees its whole triangle (`vs_cloth_strain` in
//! `shaders/render/mesh.wgsl`).

use wgpu::util::DeviceExt;

use super::RendererFormats;
use crate::gpu::GpuSolver;
use crate::model::Model;
use crate::params::Params;

/// The strain shown red when the stretch springs have no `max_stretch`
/// (10 %).
const DEFAULT_FULL_SCALE: f64 = 0.1;

/// The strain shown red for `params`: the stretch springs' largest allowed
/// strain (`max_stretch − 1`) if they have one, else 10 %.
pub fn full_scale(params: &Params) -> f32 {
    let stretch = params.springs[crate::params::SpringKind::Stretch.index()];
    stretch
        .max_stretch
        .map_or(DEFAULT_FULL_SCALE, |m| m - 1.0)
        .max(1e-6) as f32
}

/// The strain pipeline and its bind group for one solver.
#[derive(Debug)]
pub(super) struct StrainView {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    vertices: u32,
}

impl StrainView {
    /// Builds the view of `solver`, made from `model`, drawing into
    /// targets of `formats`. `globals` is the renderer's group-0 layout.
    pub(super) fn new(
        device: &wgpu::Device,
        shader: &wgpu::ShaderModule,
        globals: &wgpu::BindGroupLayout,
        formats: RendererFormats,
        model: &Model,
        solver: &GpuSolver,
    ) -> StrainView {
        let storage = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wgcloth.render.strain"),
            entries: &[storage(0), storage(1), storage(2), storage(3)],
        });
        let rest: Vec<[f32; 4]> = model
            .rest_positions
            .iter()
            .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32, 0.0])
            .collect();
        let buffer = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let rest = buffer("wgcloth.render.strain.rest", bytemuck::cast_slice(&rest));
        let triangles = buffer(
            "wgcloth.render.strain.triangles",
            bytemuck::cast_slice(&model.triangles),
        );
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wgcloth.render.strain"),
            layout: &layout,
            entries: &[
                entry(0, solver.positions_buffer()),
                entry(1, solver.normals_buffer()),
                entry(2, &rest),
                entry(3, &triangles),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wgcloth.render.strain"),
            bind_group_layouts: &[Some(globals), Some(&layout)],
            immediate_size: 0,
        });
        let constants = formats.constants();
        let targets = [Some(formats.color.into())];
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("wgcloth.render.strain"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: shader,
                entry_point: Some("vs_cloth_strain"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            // Two-sided, like the cloth.
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(super::depth_state(formats.depth)),
            multisample: Default::default(),
            fragment: Some(super::fragment_state(shader, &constants, &targets)),
            multiview_mask: None,
            cache: None,
        });
        StrainView {
            pipeline,
            bind_group,
            vertices: model.triangles.len() as u32 * 3,
        }
    }

    /// Records the cloth, coloured by strain, into `pass` (group 0 set).
    pub(super) fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.draw(0..self.vertices, 0..1);
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}
