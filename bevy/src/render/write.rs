//! `write_vertices` (`src/shaders/write_vertices.wgsl`): the compute pass
//! that copies a cloth's positions and normals from the solver's buffers
//! into its Bevy mesh's slice of the mesh allocator's vertex slab, so the
//! mesh is drawn by Bevy's own pipelines with nothing read back.

use std::num::NonZeroU64;

use bevy::mesh::{Mesh, MeshVertexAttribute, MeshVertexBufferLayoutRef};
use bevy::render::mesh::allocator::MeshBufferSlice;
use bytemuck::{Pod, Zeroable};
use wgcloth::gpu::DrawRange;

/// The WGSL source.
pub(crate) const SOURCE: &str = include_str!("../shaders/write_vertices.wgsl");

/// Invocations per workgroup (`@workgroup_size` in the shader).
const WORKGROUP: u32 = 64;

/// Where one cloth's vertices go: the twin of `WriteLayout` in
/// `write_vertices.wgsl` (a uniform block: its size a multiple of 16).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub(crate) struct WriteLayout {
    /// The cloth's first particle in the solver's buffers.
    pub(crate) source: u32,
    /// The mesh's first vertex in the bound slab range \[words\].
    pub(crate) base: u32,
    /// Words per vertex.
    pub(crate) stride: u32,
    /// Word offset of the position within a vertex.
    pub(crate) position: u32,
    /// Word offset of the normal within a vertex.
    pub(crate) normal: u32,
    /// Vertices.
    pub(crate) count: u32,
    pad: [u32; 2],
}

const _: () = assert!(std::mem::size_of::<WriteLayout>() == 32);

/// The pipeline, built once on Bevy's device.
#[derive(Debug)]
pub(crate) struct WritePipeline {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl WritePipeline {
    /// Builds the pipeline; a device error (there should be none: the
    /// shader is validated by the tests) is returned as its message.
    pub(crate) fn new(device: &wgpu::Device) -> Result<WritePipeline, String> {
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("wgcloth_bevy.write_vertices"),
                entries: &[
                    storage(0, true),
                    storage(1, true),
                    storage(2, false),
                    wgpu::BindGroupLayoutEntry {
                        binding: 3,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: NonZeroU64::new(
                                std::mem::size_of::<WriteLayout>() as u64
                            ),
                        },
                        count: None,
                    },
                ],
            });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("wgcloth_bevy.write_vertices"),
            source: wgpu::ShaderSource::Wgsl(SOURCE.into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wgcloth_bevy.write_vertices"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("wgcloth_bevy.write_vertices"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("write_vertices"),
            compilation_options: Default::default(),
            cache: None,
        });
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(format!("building the vertex-writing pass: {e}")),
            None => Ok(WritePipeline { layout, pipeline }),
        }
    }
}

/// Word offsets of the position and normal in a mesh's vertex, and its
/// stride: both must be uncompressed `Float32x3`. `what` names the mesh in
/// messages ("the cloth's mesh").
pub(crate) fn vertex_words(
    layout: &MeshVertexBufferLayoutRef,
    what: &str,
) -> Result<(u32, u32, u32), String> {
    if !layout.0.get_attribute_compression().is_empty() {
        return Err(format!(
            "{what} has compressed vertex attributes; \
             it needs Float32x3 positions and normals"
        ));
    }
    let find = |attribute: MeshVertexAttribute, name: &str| {
        let at = layout
            .0
            .attribute_ids()
            .iter()
            .position(|a| *a == attribute.id);
        match at.and_then(|i| layout.0.layout().attributes.get(i)) {
            Some(a) if a.format == wgpu::VertexFormat::Float32x3 => Ok((a.offset / 4) as u32),
            Some(a) => Err(format!(
                "{what} has {name} of format {:?}; it needs Float32x3",
                a.format
            )),
            None => Err(format!("{what} has no {name}")),
        }
    };
    let position = find(Mesh::ATTRIBUTE_POSITION, "positions")?;
    let normal = find(Mesh::ATTRIBUTE_NORMAL, "normals")?;
    Ok((
        (layout.0.layout().array_stride / 4) as u32,
        position,
        normal,
    ))
}

/// A whole buffer at `binding`.
fn whole(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// What a bind group binds: the solver's positions and normals, the slab
/// and its bound range \[bytes\], and the uniform block's contents.
type Bound = (
    wgpu::Buffer,
    wgpu::Buffer,
    wgpu::Buffer,
    u64,
    u64,
    WriteLayout,
);

/// One cloth's binding for the pass: its uniform block and bind group.
#[derive(Debug)]
pub(crate) struct WriteBinding {
    uniform: wgpu::Buffer,
    bind_group: Option<wgpu::BindGroup>,
    workgroups: u32,
    /// What `bind_group` binds (rebuilt only when it changes).
    bound: Option<Bound>,
}

impl WriteBinding {
    /// A binding with its uniform block (bound by [`WriteBinding::update`]).
    pub(crate) fn new(device: &wgpu::Device) -> WriteBinding {
        WriteBinding {
            uniform: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("wgcloth_bevy.write_vertices.layout"),
                size: std::mem::size_of::<WriteLayout>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            bind_group: None,
            workgroups: 0,
            bound: None,
        }
    }

    /// Binds this frame's buffers: the cloth's `range` in the solver's
    /// buffers and its mesh's `slice` of the vertex slab (a slab can move
    /// when meshes are added, a batch's buffers when cloths are); the bind
    /// group and uniform block are remade only when one of them moved.
    /// `words` is [`vertex_words`]'s answer for the mesh. A mesh whose
    /// vertex count is not the cloth's particle count is refused.
    #[expect(
        clippy::too_many_arguments,
        reason = "each is one piece of the binding"
    )]
    pub(crate) fn update(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipeline: &WritePipeline,
        range: &DrawRange<'_>,
        particles: u32,
        slice: &MeshBufferSlice<'_>,
        words: (u32, u32, u32),
    ) -> Result<(), String> {
        let (stride, position, normal) = words;
        let vertices = slice.range.end - slice.range.start;
        if vertices != particles {
            return Err(format!(
                "the cloth's mesh has {vertices} vertices for its {particles} particles \
                 (a cloth's mesh has one vertex per particle, in particle order)"
            ));
        }
        let stride_bytes = u64::from(stride) * 4;
        // The slab is bound from the alignment boundary below the mesh.
        let align = u64::from(device.limits().min_storage_buffer_offset_alignment);
        let start = u64::from(slice.range.start) * stride_bytes;
        let offset = start / align * align;
        let size = u64::from(slice.range.end) * stride_bytes - offset;
        let layout = WriteLayout {
            source: u32::try_from(range.base_vertex).map_err(|e| e.to_string())?,
            base: ((start - offset) / 4) as u32,
            stride,
            position,
            normal,
            count: particles,
            pad: [0; 2],
        };
        let bound = (
            range.positions.clone(),
            range.normals.clone(),
            wgpu::Buffer::clone(slice.buffer),
            offset,
            size,
            layout,
        );
        if self.bind_group.is_some() && self.bound.as_ref() == Some(&bound) {
            return Ok(());
        }
        self.bound = None;
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&layout));
        let entries = [
            whole(0, range.positions),
            whole(1, range.normals),
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: slice.buffer,
                    offset,
                    size: NonZeroU64::new(size),
                }),
            },
            whole(3, &self.uniform),
        ];
        self.bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wgcloth_bevy.write_vertices"),
            layout: &pipeline.layout,
            entries: &entries,
        }));
        self.workgroups = particles.div_ceil(WORKGROUP);
        let most = device.limits().max_compute_workgroups_per_dimension;
        if self.workgroups > most {
            self.bind_group = None;
            self.bound = None;
            return Err(format!(
                "the cloth's {particles} particles need {} workgroups to write its mesh; \
                 the device allows {most}",
                self.workgroups
            ));
        }
        self.bound = Some(bound);
        Ok(())
    }

    /// Records the pass's dispatch for this cloth into `pass`.
    pub(crate) fn record(&self, pass: &mut wgpu::ComputePass<'_>, pipeline: &WritePipeline) {
        if let Some(bind_group) = &self.bind_group {
            pass.set_pipeline(&pipeline.pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(self.workgroups, 1, 1);
        }
    }
}
