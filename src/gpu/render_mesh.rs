//! A render mesh on the device: its embedding uploaded once, and one
//! `skin` dispatch a frame that writes its vertices into a vertex buffer
//! the host draws (see [`crate::render_mesh`]): the render mesh's own, or
//! a range of the host's ([`GpuRenderMesh::write_into`]: a game engine's
//! mesh slab).

use std::num::NonZeroU64;

use super::buffers::init;
use super::errors::guarded;
use super::kernel::{Kernel, Variant};
use super::kernels::{Features, GpuKernels};
use super::readback::read_buffers;
use super::{ClothId, DrawRange, GpuBatch, GpuSolver};
use crate::error::{Error, Result};
use crate::kernel_config::WORKGROUP;
use crate::render_mesh::{Embedded, Embedding};

/// Where each render vertex lies in the vertex buffer, in `f32` words:
/// three of position and three of normal, written by the `skin` pass, and
/// two of texture coordinates, written once when the buffer is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SkinLayout {
    /// Words from one vertex to the next.
    pub stride: u32,
    /// The word of the position's x within a vertex.
    pub position: u32,
    /// The word of the normal's x within a vertex (`None`: not written).
    pub normal: Option<u32>,
    /// The word of the texture coordinates' u within a vertex (`None`: not
    /// written; `Some` needs a mesh that has them).
    pub uv: Option<u32>,
}

impl SkinLayout {
    /// `[px py pz nx ny nz]`: a position and a normal attribute of format
    /// `Float32x3` at byte offsets 0 and 12, stride 24; what
    /// [`Renderer`](crate::render::Renderer) draws.
    pub const POSITION_NORMAL: SkinLayout = SkinLayout {
        stride: 6,
        position: 0,
        normal: Some(3),
        uv: None,
    };

    /// `[px py pz nx ny nz u v]`: [`SkinLayout::POSITION_NORMAL`] and a
    /// `Float32x2` texture coordinate at byte offset 24, stride 32.
    pub const POSITION_NORMAL_UV: SkinLayout = SkinLayout {
        stride: 8,
        position: 0,
        normal: Some(3),
        uv: Some(6),
    };

    /// The `(first word, words)` of each attribute the layout has.
    fn attributes(&self) -> Vec<(u32, u32)> {
        let mut out = vec![(self.position, 3)];
        out.extend(self.normal.map(|n| (n, 3)));
        out.extend(self.uv.map(|t| (t, 2)));
        out
    }

    /// Refuses a layout whose attributes overlap or leave the stride.
    fn check(&self) -> Result<()> {
        let ranges = self.attributes();
        let fits = ranges
            .iter()
            .all(|&(at, n)| at.checked_add(n).is_some_and(|end| end <= self.stride));
        let apart = ranges.iter().enumerate().all(|(i, &(a, n))| {
            ranges[i + 1..]
                .iter()
                .all(|&(b, m)| a.saturating_add(n) <= b || b.saturating_add(m) <= a)
        });
        if fits && apart {
            Ok(())
        } else {
            Err(Error::InvalidParameter {
                key: "SkinLayout".into(),
                allowed: "three words of position, three of normal and two of texture \
                          coordinates, apart, each inside the stride"
                    .into(),
                got: format!("{self:?}"),
            })
        }
    }
}

/// The `skin` kernel's uniform block (`SkinParams` in `shaders/skin.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SkinParams {
    count: u32,
    stride: u32,
    position: u32,
    normal: u32,
    first_index: u32,
    base_vertex: i32,
    base: u32,
    pad: u32,
}

/// `SkinParams::normal` when no normal is written (`NO_NORMAL`).
const NO_NORMAL: u32 = u32::MAX;

/// A render mesh bound to one cloth (a [`GpuSolver`]'s or a
/// [`GpuBatch`]'s): its vertex buffer (written by
/// [`GpuRenderMesh::encode`]) and index buffer.
#[derive(Debug)]
pub struct GpuRenderMesh {
    /// The buffer the pass writes: the render mesh's own, or the host's.
    vertices: wgpu::Buffer,
    /// The first render vertex's byte in `vertices`.
    offset: u64,
    indices: wgpu::Buffer,
    index_count: u32,
    vertex_count: u32,
    layout: SkinLayout,
    /// The cloth of the world it is drawn in place of (`None`: all).
    follows: Option<usize>,
    params: SkinParams,
    /// The embedding and the uniform block, bound with `vertices` and the
    /// cloth's buffers (`cloth`: positions, normals, indices) in `group`.
    embedded: wgpu::Buffer,
    uniform: wgpu::Buffer,
    cloth: [wgpu::Buffer; 3],
    group: wgpu::BindGroup,
    kernels: GpuKernels,
    pipeline: wgpu::ComputePipeline,
    device: wgpu::Device,
    queue: wgpu::Queue,
}

impl GpuRenderMesh {
    /// Uploads `embedding` for `solver`'s cloth, with a vertex buffer of
    /// `layout`. Refused: an embedding of another cloth (a triangle it does
    /// not have, an index past the render mesh), a bad layout, a layout
    /// with texture coordinates for a mesh without, more vertices than one
    /// dispatch reaches.
    pub fn new(
        solver: &GpuSolver,
        embedding: &Embedding,
        layout: SkinLayout,
    ) -> Result<GpuRenderMesh> {
        GpuRenderMesh::build(
            &solver.kernels,
            &solver.queue,
            &solver.draw_range(),
            embedding,
            layout,
        )
    }

    /// As [`GpuRenderMesh::new`], for cloth `id` of `batch` (where
    /// [`GpuBatch::draw_range`] says it lies). Its normals are the batch's
    /// ([`GpuBatch::encode_normals`]).
    pub fn in_batch(
        batch: &GpuBatch,
        id: ClothId,
        embedding: &Embedding,
        layout: SkinLayout,
    ) -> Result<GpuRenderMesh> {
        let range = batch.draw_range(id)?;
        GpuRenderMesh::build(batch.kernels(), batch.queue(), &range, embedding, layout)
    }

    /// The render mesh over the cloth that `range` places in its buffers.
    fn build(
        kernels: &GpuKernels,
        queue: &wgpu::Queue,
        range: &DrawRange<'_>,
        embedding: &Embedding,
        layout: SkinLayout,
    ) -> Result<GpuRenderMesh> {
        layout.check()?;
        let triangles = range.indices.len() as u32 / 3;
        if let Some((i, e)) = embedding
            .vertices
            .iter()
            .enumerate()
            .find(|(_, e)| e.triangle >= triangles)
        {
            return Err(Error::InvalidParameter {
                key: format!("Embedding::vertices[{i}].triangle"),
                allowed: format!("a triangle of this cloth, below {triangles}"),
                got: e.triangle.to_string(),
            });
        }
        let n = embedding.vertex_count();
        if let Some(t) = embedding
            .triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(Error::InvalidParameter {
                key: "Embedding::triangles".into(),
                allowed: format!("indices below the {n} render vertices"),
                got: format!("{t:?}"),
            });
        }
        let device = kernels.device();
        let limits = device.limits();
        let groups = n.div_ceil(WORKGROUP as usize);
        let bytes = n as u64 * u64::from(layout.stride) * 4;
        if groups > limits.max_compute_workgroups_per_dimension as usize
            || bytes > limits.max_storage_buffer_binding_size
        {
            return Err(Error::InvalidParameter {
                key: "the render mesh's vertices".into(),
                allowed: format!(
                    "at most {} of {} words on this device",
                    (limits.max_compute_workgroups_per_dimension as u64 * u64::from(WORKGROUP))
                        .min(
                            limits.max_storage_buffer_binding_size / (4 * u64::from(layout.stride))
                        ),
                    layout.stride
                ),
                got: n.to_string(),
            });
        }
        // The texture coordinates, written once where the layout puts them.
        let mut initial = vec![0.0f32; n * layout.stride as usize];
        if let Some(at) = layout.uv {
            let uvs = embedding
                .uvs
                .as_ref()
                .filter(|uvs| uvs.len() == n)
                .ok_or_else(|| Error::InvalidParameter {
                    key: "SkinLayout::uv".into(),
                    allowed: "None for a render mesh without texture coordinates (one per \
                              vertex)"
                        .into(),
                    got: format!("Some({at})"),
                })?;
            for (k, t) in uvs.iter().enumerate() {
                let w = k * layout.stride as usize + at as usize;
                initial[w..w + 2].copy_from_slice(t);
            }
        }
        let pipeline = kernels
            .pipelines([(Kernel::Skin, Variant::Plain)], Features::default())?
            .remove(&(Kernel::Skin, Variant::Plain))
            .ok_or_else(|| Error::Gpu("the skin kernel was not compiled".into()))?;
        let need = bytes + n as u64 * std::mem::size_of::<Embedded>() as u64;
        guarded(device, "the render mesh's buffers", Some(need), || {
            let embedded = init(
                device,
                "wgcloth.render_mesh.embedding",
                bytemuck::cast_slice(&embedding.vertices),
                wgpu::BufferUsages::STORAGE,
            );
            let vertices = init(
                device,
                "wgcloth.render_mesh.vertices",
                bytemuck::cast_slice(&initial),
                wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::VERTEX
                    | wgpu::BufferUsages::COPY_SRC,
            );
            let flat: Vec<u32> = embedding.triangles.iter().flatten().copied().collect();
            let indices = init(
                device,
                "wgcloth.render_mesh.indices",
                bytemuck::cast_slice(&flat),
                wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_SRC,
            );
            let params = SkinParams {
                count: n as u32,
                stride: layout.stride,
                position: layout.position,
                normal: layout.normal.unwrap_or(NO_NORMAL),
                first_index: range.indices.start,
                base_vertex: range.base_vertex,
                base: 0,
                pad: 0,
            };
            let uniform = init(
                device,
                "wgcloth.render_mesh.params",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            );
            let cloth = [
                range.positions.clone(),
                range.normals.clone(),
                range.index_buffer.clone(),
            ];
            let group = bind(kernels, &embedded, &uniform, &cloth, &vertices, 0, bytes);
            Ok(GpuRenderMesh {
                vertices,
                offset: 0,
                indices,
                index_count: flat.len() as u32,
                vertex_count: n as u32,
                layout,
                follows: embedding.cloth,
                params,
                embedded,
                uniform,
                cloth,
                group,
                kernels: kernels.clone(),
                pipeline,
                device: device.clone(),
                queue: queue.clone(),
            })
        })
    }

    /// From now on, writes the render mesh's vertices into the host's
    /// `buffer` from byte `offset` (a multiple of 4) in `layout`, and
    /// leaves the words between its attributes as they are: a game
    /// engine's mesh slab, whose texture coordinates, tangents and colours
    /// are its own (so `layout` has no `uv`). The buffer needs
    /// [`wgpu::BufferUsages::STORAGE`]. Called again with the same buffer,
    /// offset and layout it does nothing, so a host may call it every frame
    /// (a slab moves when meshes are added). The render mesh's own vertex
    /// buffer is dropped. Refused: a layout with texture coordinates or
    /// that [`GpuRenderMesh::new`] refuses, an offset not a multiple of 4,
    /// a buffer without `STORAGE` or too small for the vertices, a range
    /// longer than one storage binding on this device.
    pub fn write_into(
        &mut self,
        buffer: &wgpu::Buffer,
        offset: u64,
        layout: SkinLayout,
    ) -> Result<()> {
        if *buffer == self.vertices && offset == self.offset && layout == self.layout {
            return Ok(());
        }
        layout.check()?;
        let refuse = |key: &str, allowed: String, got: String| Error::InvalidParameter {
            key: format!("GpuRenderMesh::write_into {key}"),
            allowed,
            got,
        };
        if let Some(uv) = layout.uv {
            return Err(refuse(
                "layout.uv",
                "None: a host's buffer holds its own texture coordinates".into(),
                format!("Some({uv})"),
            ));
        }
        if !offset.is_multiple_of(4) {
            return Err(refuse(
                "offset",
                "a multiple of 4 bytes".into(),
                offset.to_string(),
            ));
        }
        if !buffer.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(refuse(
                "buffer",
                "a buffer with STORAGE usage".into(),
                format!("{:?}", buffer.usage()),
            ));
        }
        let bytes = u64::from(self.vertex_count) * u64::from(layout.stride) * 4;
        let end = offset
            .checked_add(bytes)
            .filter(|&end| end <= buffer.size())
            .ok_or_else(|| {
                refuse(
                    "offset",
                    format!(
                        "room for {} vertices of {} words in the buffer's {} bytes",
                        self.vertex_count,
                        layout.stride,
                        buffer.size()
                    ),
                    offset.to_string(),
                )
            })?;
        // Bound from the alignment boundary below the first vertex; the
        // kernel adds the words from there.
        let limits = self.device.limits();
        let align = u64::from(limits.min_storage_buffer_offset_alignment);
        let start = offset / align * align;
        if end - start > limits.max_storage_buffer_binding_size {
            return Err(refuse(
                "offset",
                format!(
                    "a range of at most {} bytes on this device",
                    limits.max_storage_buffer_binding_size
                ),
                format!("{} bytes from {start}", end - start),
            ));
        }
        let params = SkinParams {
            stride: layout.stride,
            position: layout.position,
            normal: layout.normal.unwrap_or(NO_NORMAL),
            base: ((offset - start) / 4) as u32,
            ..self.params
        };
        let group = guarded(&self.device, "the render mesh's target", None, || {
            self.queue
                .write_buffer(&self.uniform, 0, bytemuck::bytes_of(&params));
            Ok(bind(
                &self.kernels,
                &self.embedded,
                &self.uniform,
                &self.cloth,
                buffer,
                start,
                end - start,
            ))
        })?;
        self.group = group;
        self.params = params;
        self.vertices = buffer.clone();
        self.offset = offset;
        self.layout = layout;
        Ok(())
    }

    /// Records the `skin` pass into `encoder`: one dispatch that writes the
    /// vertex buffer from the cloth's buffers as they are when the pass
    /// runs. The cloth's normals must have been recorded
    /// ([`GpuSolver::encode_normals`], [`GpuBatch::encode_normals`]) since
    /// its last step.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wgcloth.skin"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(self.vertex_count.div_ceil(WORKGROUP), 1, 1);
    }

    /// The vertex buffer: [`GpuRenderMesh::vertex_count`] vertices of
    /// [`GpuRenderMesh::layout`] from byte [`GpuRenderMesh::vertex_offset`],
    /// written by [`GpuRenderMesh::encode`] (the host's after
    /// [`GpuRenderMesh::write_into`]).
    pub fn vertex_buffer(&self) -> &wgpu::Buffer {
        &self.vertices
    }

    /// The first render vertex's byte in [`GpuRenderMesh::vertex_buffer`]
    /// (0 unless [`GpuRenderMesh::write_into`] said otherwise).
    pub fn vertex_offset(&self) -> u64 {
        self.offset
    }

    /// The render mesh's triangles (`u32`, three per triangle) as an index
    /// buffer.
    pub fn index_buffer(&self) -> &wgpu::Buffer {
        &self.indices
    }

    /// Number of indices in [`GpuRenderMesh::index_buffer`].
    pub fn index_count(&self) -> u32 {
        self.index_count
    }

    /// Number of render vertices.
    pub fn vertex_count(&self) -> u32 {
        self.vertex_count
    }

    /// Where each vertex's position and normal lie in the vertex buffer.
    pub fn layout(&self) -> SkinLayout {
        self.layout
    }

    /// The cloth of the world it follows and is drawn in place of (its
    /// embedding's [`Embedding::cloth`]); `None`: every cloth.
    pub fn follows(&self) -> Option<usize> {
        self.follows
    }

    /// Reads the vertex buffer back: `vertex_count × stride` words from
    /// [`GpuRenderMesh::vertex_offset`] (native only; for tests and the
    /// CLI, never per frame; a host's buffer needs `COPY_SRC`).
    pub fn read_vertices(&self) -> Result<Vec<f32>> {
        let bytes = u64::from(self.vertex_count) * u64::from(self.layout.stride) * 4;
        let parts = read_buffers(
            &self.device,
            &self.queue,
            &[(&self.vertices, self.offset, bytes)],
        )?;
        Ok(bytemuck::pod_collect_to_vec(&parts[0]))
    }
}

/// The `skin` kernel's bind group: the embedding, `size` bytes of `target`
/// from byte `start`, the uniform block and the cloth's positions, normals
/// and indices.
fn bind(
    kernels: &GpuKernels,
    embedded: &wgpu::Buffer,
    uniform: &wgpu::Buffer,
    cloth: &[wgpu::Buffer; 3],
    target: &wgpu::Buffer,
    start: u64,
    size: u64,
) -> wgpu::BindGroup {
    fn whole(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
        wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        }
    }
    kernels
        .device()
        .create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wgcloth.render_mesh"),
            layout: kernels.skin_group(),
            entries: &[
                whole(0, embedded),
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: target,
                        offset: start,
                        size: NonZeroU64::new(size),
                    }),
                },
                whole(2, uniform),
                whole(3, &cloth[0]),
                whole(4, &cloth[1]),
                whole(5, &cloth[2]),
            ],
        })
}
