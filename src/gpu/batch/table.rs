//! The cloths a batch steps with the workgroup kernels: their data in
//! shared buffers, each cloth at offsets of its own (where: `ranges.rs`),
//! and the cloth table the kernels read (an entry per slot of the batch,
//! `Params` with the cloth's bases; a zero particle count where the slot
//! holds no table cloth, which the kernels skip). One dispatch per
//! integrator present steps every table cloth, a workgroup each.
//!
//! Adding a cloth reserves its ranges (a removed cloth's, where they fit),
//! grows a buffer that is too small by allocating a larger one and copying
//! the old contents on the device (so the other cloths' state is kept
//! bit for bit), and rebuilds the bind groups; pipelines are taken from
//! the shared kernel library, compiled with every scene feature (each
//! cloth skips what it lacks by its `params.features` bits).

use super::ranges::{grown, Extents, Layout, Region, REGIONS};
use crate::budget;
use crate::error::{Error, Result};
use crate::gpu::buffers::buffers_group;
use crate::gpu::build::ClothArrays;
use crate::gpu::guarded;
use crate::gpu::kernel::Dispatch;
use crate::gpu::kernels::{Features, GpuKernels};
use crate::gpu::layout::{GpuParams, GpuSpring};
use crate::gpu::path::StepPath;
use crate::gpu::solver::{limit, plan_inputs, Prepared};
use crate::kernel_config::status;
use crate::params::Integrator;

/// Bytes of one element of each [`Region`].
const ELEMENT_BYTES: Extents = [16, 16, 16, 4, 4];

/// The smallest buffer made \[bytes\]: a binding must hold one element of
/// its array, and a batch may have no spring, no dense filter, no cloth
/// yet; the largest thing read is a spring record.
const MIN_BUFFER: u64 = std::mem::size_of::<GpuSpring>() as u64;

/// Bytes of a cloth table entry.
const ENTRY_BYTES: u64 = std::mem::size_of::<GpuParams>() as u64;

/// Usage of the shared storage buffers: bound, written by the host, read
/// back and copied when they grow.
const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::COPY_SRC);

/// The usage of each region's buffer.
fn usage(region: Region) -> wgpu::BufferUsages {
    match region {
        Region::Particles => STORAGE | wgpu::BufferUsages::VERTEX,
        // STORAGE: a render mesh's skin pass reads it.
        Region::Indices => STORAGE | wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_SRC,
        _ => STORAGE,
    }
}

/// The label of each region's buffer.
fn label(region: Region) -> &'static str {
    match region {
        Region::Particles => "wgcloth.batch.particles",
        Region::Model => "wgcloth.batch.model",
        Region::Work => "wgcloth.batch.work",
        Region::Status => "wgcloth.batch.status",
        Region::Indices => "wgcloth.batch.indices",
    }
}

/// What a cloth of the table holds in each region \[elements\].
pub(super) fn extents(a: &ClothArrays, triangles: usize) -> Extents {
    let mut e = [0; REGIONS];
    e[Region::Particles.index()] = u64::from(a.params.particle_count);
    e[Region::Model.index()] = a.model_len();
    e[Region::Work.index()] = a.work_len();
    e[Region::Status.index()] = a.status_len();
    e[Region::Indices.index()] = 3 * triangles as u64;
    e
}

/// Moves a cloth's arrays, built as a lone cloth's (every index from 0),
/// to where it lives in the shared buffers: particle indices become
/// global, and its parameters get its bases (the contract of
/// `shaders/common/layout.wgsl`; springs stay numbered within the cloth).
pub(super) fn place(a: &mut ClothArrays, starts: &Extents) {
    let base = |r: Region| starts[r.index()];
    let pb = base(Region::Particles) as u32;
    for s in &mut a.springs {
        s.i += pb;
        s.j += pb;
    }
    let p = &a.params;
    let entries = p.spring_adj_entries as usize;
    let count = a.topo[p.particle_count as usize] as usize;
    // Each entry is `spring << 1 | end`; then each entry's other particle.
    for other in &mut a.topo[entries + count..entries + 2 * count] {
        *other += pb;
    }
    let triangles = p.triangles as usize;
    for q in &mut a.topo[triangles..triangles + 3 * p.triangle_count as usize] {
        *q += pb;
    }
    shift_order(&mut a.dense, p.filter_count, pb);
    a.place(base(Region::Model), base(Region::Work));
    a.params.particle_base = pb;
    a.params.status_base = base(Region::Status) as u32;
}

/// Features with what either has: the kernel variants that step cloths
/// of both.
pub(super) fn either(a: Features, b: Features) -> Features {
    Features {
        wind: a.wind || b.wind,
        ground: a.ground || b.ground,
        spheres: a.spheres || b.spheres,
        filter: a.filter || b.filter,
        damping: a.damping || b.damping,
        coarse: a.coarse || b.coarse,
        constant_blocks: a.constant_blocks || b.constant_blocks,
        ..a
    }
}

/// Makes the particles of a dense filter's order (`count` of them after
/// its `count²` matrix words, as `u32` bits) global: `base` added.
pub(super) fn shift_order(words: &mut [f32], count: u32, base: u32) {
    let f = count as usize;
    for q in words.iter_mut().skip(f * f).take(f) {
        *q = f32::from_bits(q.to_bits() + base);
    }
}

/// The shared buffers, the cloth table and the bind group over them.
#[derive(Debug)]
pub(super) struct Table {
    kernels: GpuKernels,
    queue: wgpu::Queue,
    layout: Layout,
    /// A buffer per [`Region`], holding `capacity` elements.
    buffers: Vec<wgpu::Buffer>,
    /// Velocities and vertex normals: as [`Region::Particles`] (which
    /// holds the positions), element for element.
    v: wgpu::Buffer,
    normals: wgpu::Buffer,
    capacity: Extents,
    /// The cloth table: an entry per slot of the batch.
    cloths: wgpu::Buffer,
    /// Entries `cloths` holds.
    entries: u64,
    /// Group 0 of the workgroup kernels over these buffers.
    group: wgpu::BindGroup,
    /// A workgroup kernel's step per integrator present, with its
    /// pipeline, compiled with every scene feature.
    steps: Vec<(Integrator, (Dispatch, wgpu::ComputePipeline))>,
    /// The vertex-normal pass for those features.
    normals_pass: Option<wgpu::ComputePipeline>,
    /// The features the pipelines were taken for.
    features: Option<Features>,
}

impl Table {
    /// An empty table (minimal buffers; nothing to step).
    pub(super) fn new(kernels: &GpuKernels, queue: &wgpu::Queue) -> Table {
        let device = kernels.device();
        let buffers: Vec<wgpu::Buffer> = Region::ALL
            .iter()
            .map(|&r| buffer(device, r, MIN_BUFFER))
            .collect();
        let v = buffer(device, Region::Particles, MIN_BUFFER);
        let normals = buffer(device, Region::Particles, MIN_BUFFER);
        let cloths = cloth_table(device, ENTRY_BYTES);
        let group = bind_group(kernels, &cloths, &buffers, &v, &normals);
        Table {
            kernels: kernels.clone(),
            queue: queue.clone(),
            layout: Layout::default(),
            buffers,
            v,
            normals,
            capacity: [0; REGIONS],
            cloths,
            entries: 1,
            group,
            steps: Vec::new(),
            normals_pass: None,
            features: None,
        }
    }

    /// The device the buffers live on.
    pub(super) fn device(&self) -> &wgpu::Device {
        self.kernels.device()
    }

    /// The queue uploads go to.
    pub(super) fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Every status word of the table cloths (one read-back; none when
    /// there is no table cloth).
    pub(super) async fn read_status(&self) -> Result<Vec<u32>> {
        let words = self.layout.ends()[Region::Status.index()];
        if words == 0 {
            return Ok(Vec::new());
        }
        let status = self.buffer(Region::Status);
        let bytes = self.read(&[(status, Region::Status, 0, words)]).await?;
        Ok(bytemuck::pod_collect_to_vec(&bytes[0]))
    }

    /// One step's dispatches as `wgcloth run --verbose` lists them:
    /// `(kernel, dispatches, invocations each)` over `slots` table entries.
    pub(super) fn describe_step(&self, slots: u32) -> Vec<(&'static str, u32, u32)> {
        self.steps
            .iter()
            .map(|(_, (d, _))| (d.kernel.name(), 1, slots * d.items))
            .collect()
    }

    /// The buffer of `region`.
    pub(super) fn buffer(&self, region: Region) -> &wgpu::Buffer {
        &self.buffers[region.index()]
    }

    /// The velocities (as [`Region::Particles`]).
    pub(super) fn velocities(&self) -> &wgpu::Buffer {
        &self.v
    }

    /// The vertex normals (as [`Region::Particles`]).
    pub(super) fn normals(&self) -> &wgpu::Buffer {
        &self.normals
    }

    /// Reserves a cloth's ranges, growing the buffers that are too small
    /// (after checking the device's limits and the host's memory); the
    /// starts. Nothing is reserved when it fails.
    pub(super) fn reserve(&mut self, lens: &Extents, slots: u64) -> Result<Extents> {
        let starts = self.layout.reserve(lens);
        if let Err(e) = self.fit(slots) {
            self.layout.free(&starts, lens);
            return Err(e);
        }
        Ok(starts)
    }

    /// Frees a removed cloth's ranges and zeroes its table entry (the
    /// kernels skip it).
    pub(super) fn free(&mut self, slot: u32, starts: &Extents, lens: &Extents) {
        self.layout.free(starts, lens);
        self.write_entry(slot, &bytemuck::Zeroable::zeroed());
    }

    /// Grows what is too small for the ranges in use and `slots` table
    /// entries.
    fn fit(&mut self, slots: u64) -> Result<()> {
        let device = self.kernels.device().clone();
        let ends = self.layout.ends();
        let wanted: Extents = std::array::from_fn(|k| grown(self.capacity[k], ends[k].max(1)));
        let entries = grown(self.entries, slots.max(1));
        let limits = device.limits();
        let mut new_bytes = 0u64;
        for r in Region::ALL {
            let k = r.index();
            if wanted[k] == self.capacity[k] {
                continue;
            }
            let bytes = wanted[k].saturating_mul(ELEMENT_BYTES[k]);
            let what = format!("the batch's {} buffer (bytes)", label(r));
            limit("max_buffer_size", &what, limits.max_buffer_size, bytes)?;
            if r != Region::Indices {
                limit(
                    "max_storage_buffer_binding_size",
                    &what,
                    limits.max_storage_buffer_binding_size,
                    bytes,
                )?;
            }
            new_bytes = new_bytes.saturating_add(bytes);
        }
        let table_bytes = entries.saturating_mul(ENTRY_BYTES);
        if entries != self.entries {
            limit(
                "max_storage_buffer_binding_size",
                "the batch's cloth table (bytes)",
                limits.max_storage_buffer_binding_size,
                table_bytes,
            )?;
            new_bytes = new_bytes.saturating_add(table_bytes);
        }
        if new_bytes == 0 {
            return Ok(());
        }
        budget::check_gpu_host(&device, 0, new_bytes, || {
            "the batch's larger buffers".to_string()
        })?;
        guarded(
            &device,
            "growing the batch's buffers",
            Some(new_bytes),
            || {
                let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("wgcloth.batch.grow"),
                });
                for r in Region::ALL {
                    let k = r.index();
                    if wanted[k] == self.capacity[k] {
                        continue;
                    }
                    let bytes = wanted[k] * ELEMENT_BYTES[k];
                    let mut copy = |old: &mut wgpu::Buffer| {
                        let new = buffer(&device, r, bytes);
                        encoder.copy_buffer_to_buffer(old, 0, &new, 0, old.size());
                        *old = new;
                    };
                    copy(&mut self.buffers[k]);
                    if r == Region::Particles {
                        copy(&mut self.v);
                        copy(&mut self.normals);
                    }
                    self.capacity[k] = wanted[k];
                }
                if entries != self.entries {
                    let new = cloth_table(&device, table_bytes);
                    encoder.copy_buffer_to_buffer(&self.cloths, 0, &new, 0, self.cloths.size());
                    self.cloths = new;
                    self.entries = entries;
                }
                // Submitted now: the new cloth's uploads, queued next, land
                // after the old contents are copied.
                self.queue.submit([encoder.finish()]);
                self.group = bind_group(
                    &self.kernels,
                    &self.cloths,
                    &self.buffers,
                    &self.v,
                    &self.normals,
                );
                Ok(())
            },
        )
    }

    /// Uploads a placed cloth's arrays (`model`: its words of the model
    /// buffer) and `triangles` to its ranges and its entry into slot
    /// `slot` of the table; zeroes its scratch range (a reused range holds
    /// its last cloth's) and sets its status words.
    pub(super) fn upload(
        &self,
        slot: u32,
        a: &ClothArrays,
        model: &[u32],
        triangles: &[[u32; 3]],
        starts: &Extents,
    ) {
        let q = &self.queue;
        let at = |r: Region| starts[r.index()] * ELEMENT_BYTES[r.index()];
        let write = |r: Region, bytes: &[u8]| {
            if !bytes.is_empty() {
                q.write_buffer(self.buffer(r), at(r), bytes);
            }
        };
        write(Region::Model, bytemuck::cast_slice(model));
        write(Region::Particles, bytemuck::cast_slice(&a.x));
        q.write_buffer(&self.v, at(Region::Particles), bytemuck::cast_slice(&a.v));
        write(Region::Indices, bytemuck::cast_slice(triangles));
        let lens = extents(a, triangles.len());
        // The status words, then self-collision's counters at zero (the
        // range may have held another cloth's words).
        let mut words = vec![0u32; lens[Region::Status.index()] as usize];
        words[status::BAD_STEP] = u32::MAX;
        words[status::BAD_PARTICLE] = u32::MAX;
        write(Region::Status, bytemuck::cast_slice(&words));
        self.write_entry(slot, &a.params);
        let device = self.kernels.device();
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("wgcloth.batch.clear"),
        });
        let r = Region::Work;
        let bytes = lens[r.index()] * ELEMENT_BYTES[r.index()];
        if bytes > 0 {
            encoder.clear_buffer(self.buffer(r), at(r), Some(bytes));
        }
        self.queue.submit([encoder.finish()]);
    }

    /// Writes table entry `slot`.
    pub(super) fn write_entry(&self, slot: u32, params: &GpuParams) {
        self.queue.write_buffer(
            &self.cloths,
            u64::from(slot) * ENTRY_BYTES,
            bytemuck::bytes_of(params),
        );
    }

    /// Takes the pipelines of every integrator in `present` for the union
    /// `features` with every scene feature added (compiling those the
    /// library lacks); none without.
    pub(super) fn prepare(
        &mut self,
        present: &[Integrator],
        features: Option<Features>,
    ) -> Result<()> {
        // Never fewer features than before: a pipeline with a feature a
        // cloth lacks gives it the same bits, so removing a cloth compiles
        // nothing.
        let features = match (self.features, features) {
            (Some(a), Some(b)) => Some(either(a, b)),
            (a, b) => b.or(a),
        }
        .map(Features::with_every_scene_feature);
        if self.steps.iter().map(|s| s.0).eq(present.iter().copied()) && features == self.features {
            // What a setter called every frame finds: nothing to take.
            return Ok(());
        }
        let mut steps = Vec::new();
        let mut normals = None;
        for (&integrator, features) in present.iter().zip(std::iter::repeat(features).flatten()) {
            let inputs = plan_inputs(
                integrator,
                features,
                &bytemuck::Zeroable::zeroed(),
                0,
                0,
                StepPath::Workgroup,
            );
            let prepared = Prepared::new(&self.kernels, &inputs)?;
            let step = prepared.steps.entries().next().cloned().ok_or_else(|| {
                Error::Gpu(format!(
                    "no workgroup kernel steps the {integrator} integrator"
                ))
            })?;
            steps.push((integrator, step));
            normals = Some(prepared.normals);
        }
        self.steps = steps;
        self.normals_pass = normals;
        self.features = features;
        Ok(())
    }

    /// Records `n` steps of every table cloth: per step, a dispatch of a
    /// workgroup per table entry for each integrator present. Returns the
    /// dispatches recorded.
    pub(super) fn encode_steps(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        n: u32,
        slots: u32,
    ) -> u32 {
        // Never a workgroup past the table: what it would read there is
        // the device's choice (zeros, or a clamped, live entry).
        let slots = slots.min(u32::try_from(self.entries).unwrap_or(u32::MAX));
        if self.steps.is_empty() || slots == 0 {
            return 0;
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wgcloth.batch.steps"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.group, &[]);
        for _ in 0..n {
            for (_, (_, pipeline)) in &self.steps {
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(slots, 1, 1);
            }
        }
        n * self.steps.len() as u32
    }

    /// The vertex-normal pass for the features prepared (`None` before a
    /// table cloth).
    pub(super) fn normals_pipeline(&self) -> Option<&wgpu::ComputePipeline> {
        self.normals_pass.as_ref()
    }

    /// Group 0 of the multi-dispatch kernels over the shared buffers with
    /// `params` as the uniform block: a cloth's vertex-normal pass.
    pub(super) fn uniform_group(&self, params: &wgpu::Buffer) -> wgpu::BindGroup {
        let mut entries = vec![params];
        entries.extend(group_buffers(&self.buffers, &self.v, &self.normals));
        buffers_group(
            self.kernels.device(),
            "wgcloth.batch.normals_bindings",
            self.kernels.group0(),
            &entries,
        )
    }

    /// Reads back `(buffer, region, start, elements)` parts of the shared buffers,
    /// counted in the elements of `region`.
    pub(super) async fn read(
        &self,
        parts: &[(&wgpu::Buffer, Region, u64, u64)],
    ) -> Result<Vec<Vec<u8>>> {
        let parts: Vec<(&wgpu::Buffer, u64, u64)> = parts
            .iter()
            .map(|&(b, r, start, len)| {
                let e = ELEMENT_BYTES[r.index()];
                (b, start * e, len * e)
            })
            .collect();
        crate::gpu::readback::read_buffers_async(self.kernels.device(), &self.queue, &parts).await
    }
}

/// A zeroed buffer of `region` holding `bytes` (at least [`MIN_BUFFER`]).
fn buffer(device: &wgpu::Device, region: Region, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label(region)),
        size: bytes.max(MIN_BUFFER),
        usage: usage(region),
        mapped_at_creation: false,
    })
}

/// A zeroed cloth table of `bytes`.
fn cloth_table(device: &wgpu::Device, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("wgcloth.batch.cloths"),
        size: bytes.max(ENTRY_BYTES),
        usage: STORAGE,
        mapped_at_creation: false,
    })
}

/// Bindings 1–6 (see `shaders/common/layout.wgsl`): model, x, v, work,
/// status, normals.
fn group_buffers<'a>(
    buffers: &'a [wgpu::Buffer],
    v: &'a wgpu::Buffer,
    normals: &'a wgpu::Buffer,
) -> Vec<&'a wgpu::Buffer> {
    let b = |r: Region| &buffers[r.index()];
    vec![
        b(Region::Model),
        b(Region::Particles),
        v,
        b(Region::Work),
        b(Region::Status),
        normals,
    ]
}

/// Group 0 of the workgroup kernels: the cloth table, then bindings 1–6.
fn bind_group(
    kernels: &GpuKernels,
    cloths: &wgpu::Buffer,
    buffers: &[wgpu::Buffer],
    v: &wgpu::Buffer,
    normals: &wgpu::Buffer,
) -> wgpu::BindGroup {
    let mut entries = vec![cloths];
    entries.extend(group_buffers(buffers, v, normals));
    buffers_group(
        kernels.device(),
        "wgcloth.batch.bindings",
        kernels.cloth_group0(),
        &entries,
    )
}
