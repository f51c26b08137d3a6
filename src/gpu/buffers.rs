//! A cloth's buffers on the device and the bind groups that hand them to
//! the kernels (group 0: `shaders/common/layout.wgsl`; group 1 of the
//! kernels that write indirect dispatch arguments: `shaders/common/cg.wgsl`).

use wgpu::util::DeviceExt;

use super::kernel::{arg_slots, args_words, ArgsBuffer, ArgsGroup};
use super::kernels::GpuKernels;
use super::layout::{GpuParams, GpuSpring};
use crate::budget::try_vec;
use crate::error::Result;
use crate::kernel_config::{spring_work, status};

/// What the arrays built for upload are named in a memory error.
pub(super) const UPLOAD: &str = "the GPU solver's buffers (their host copies)";

/// What the buffers are made from, built on the host.
pub(super) struct Uploads<'a> {
    /// The uniform block, placed (see `ClothArrays::place`).
    pub params: &'a GpuParams,
    /// The words of `model` (see `ClothArrays::model_words`).
    pub model: &'a [u32],
    /// `vec4` entries of `model` (the words and the dense filter's room).
    pub model_len: u64,
    /// A spring per slot (for the constant blocks).
    pub springs: &'a [GpuSpring],
    /// `vec4` entries of `work`.
    pub work_len: u64,
    /// Words of `status` (see `ClothArrays::status_len`).
    pub status_len: u64,
    /// Positions and inverse masses, velocities and masses.
    pub x: &'a [[f32; 4]],
    /// Velocities and masses.
    pub v: &'a [[f32; 4]],
    /// Triangle indices.
    pub triangles: &'a [[u32; 3]],
    /// The semi-implicit CG's constant block factor dt² \[s²\] (`None`:
    /// the blocks are computed every step, or there is no CG).
    pub constant_blocks: Option<f32>,
    /// CG iterations a step records at most.
    pub cg_max_iterations: u32,
    /// The workgroup kernels step the cloth: the parameters are also its
    /// one-entry cloth table.
    pub workgroup: bool,
}

/// A cloth's buffers and bind groups.
#[derive(Debug)]
pub(super) struct ClothBuffers {
    pub params: wgpu::Buffer,
    /// Spring records, topology and the dense filter.
    pub model: wgpu::Buffer,
    pub x: wgpu::Buffer,
    pub v: wgpu::Buffer,
    /// The per-particle and per-spring sections and the partials.
    pub work: wgpu::Buffer,
    pub status: wgpu::Buffer,
    pub normals: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    /// Indirect arguments of each CG iteration's cg_apply (see
    /// `indirect_args`).
    pub apply_args: wgpu::Buffer,
    /// Indirect arguments of each CG iteration's cg_update.
    pub update_args: wgpu::Buffer,
    /// Slots in `apply_args` and in `update_args`.
    pub arg_slots: u32,
    /// Group 0.
    pub bind_group: wgpu::BindGroup,
    /// Group 0 of the workgroup kernels (on the workgroup path): the
    /// parameters as a cloth table of one.
    pub cloth_group: Option<wgpu::BindGroup>,
    /// Group 1 of cg_init, cg_apply and cg_update ([`ArgsGroup::ALL`]
    /// order).
    pub args_groups: [wgpu::BindGroup; 3],
}

/// Usage of the storage buffers: bound, written by the host, read back.
const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::COPY_SRC);

/// The smallest storage buffer made \[bytes\]. A binding must hold at least
/// one element of its array, and a cloth may have no springs (every
/// stiffness zero): an empty array gets zeroed elements the size of the
/// largest thing read (a spring record), which no kernel reads (each stops
/// at its count).
const MIN_BINDING: usize = std::mem::size_of::<GpuSpring>();

/// A buffer holding `contents` (at least [`MIN_BINDING`] bytes).
pub(super) fn init(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    const EMPTY: [u8; MIN_BINDING] = [0; MIN_BINDING];
    let contents = if contents.is_empty() {
        &EMPTY
    } else {
        contents
    };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage,
    })
}

/// A zeroed storage buffer of `size` bytes (at least [`MIN_BINDING`]).
fn zeroed(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(MIN_BINDING as u64),
        usage: STORAGE,
        mapped_at_creation: false,
    })
}

impl ClothBuffers {
    /// The buffers a step writes and later steps read: positions,
    /// velocities, the scratch (warm start, pin goals, snapshots), the
    /// status words and CG's indirect arguments (a later solve clears the
    /// slots the status words say the last one left enabled).
    pub fn stepped(&self) -> [&wgpu::Buffer; 6] {
        [
            &self.x,
            &self.v,
            &self.work,
            &self.status,
            &self.apply_args,
            &self.update_args,
        ]
    }

    /// The buffers of `up` on `device`, bound for the kernels of `kernels`.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        kernels: &GpuKernels,
        up: &Uploads<'_>,
    ) -> Result<ClothBuffers> {
        let n = u64::from(up.params.particle_count);
        let vertex = STORAGE | wgpu::BufferUsages::VERTEX;
        let mut uniform = wgpu::BufferUsages::UNIFORM
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        if up.workgroup {
            uniform |= wgpu::BufferUsages::STORAGE;
        }
        let params = init(
            device,
            "wgcloth.params",
            bytemuck::bytes_of(up.params),
            uniform,
        );
        // Sized for the dense filter's room, which the words may not fill.
        let model = zeroed(device, "wgcloth.model", up.model_len * 16);
        queue.write_buffer(&model, 0, bytemuck::cast_slice(up.model));
        let x = init(
            device,
            "wgcloth.positions",
            bytemuck::cast_slice(up.x),
            vertex,
        );
        let v = init(
            device,
            "wgcloth.velocities",
            bytemuck::cast_slice(up.v),
            STORAGE,
        );
        let work = work_buffer(device, queue, up)?;
        let status = status_buffer(device, up.status_len)?;
        let normals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wgcloth.normals"),
            size: (n * 16).max(16),
            usage: vertex,
            mapped_at_creation: false,
        });
        let indices = init(
            device,
            "wgcloth.indices",
            bytemuck::cast_slice(up.triangles),
            // STORAGE: a render mesh's skin pass reads it.
            wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::STORAGE,
        );
        let group0 = [&params, &model, &x, &v, &work, &status, &normals];
        let bind_group = buffers_group(device, "wgcloth.bindings", kernels.group0(), &group0);
        let cloth_group = up.workgroup.then(|| {
            buffers_group(
                device,
                "wgcloth.cloth_bindings",
                kernels.cloth_group0(),
                &group0,
            )
        });
        let arg_slots = arg_slots(up.cg_max_iterations.max(1));
        let (apply_args, update_args) = indirect_args(device, arg_slots);
        let args_groups = ArgsGroup::ALL.map(|g| {
            let entries: Vec<_> = g
                .bindings()
                .iter()
                .map(|&binding| wgpu::BindGroupEntry {
                    binding,
                    resource: [&apply_args, &update_args][binding as usize].as_entire_binding(),
                })
                .collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wgcloth.args"),
                layout: kernels.args_layout(g),
                entries: &entries,
            })
        });
        Ok(ClothBuffers {
            params,
            model,
            x,
            v,
            work,
            status,
            normals,
            indices,
            apply_args,
            update_args,
            arg_slots,
            bind_group,
            cloth_group,
            args_groups,
        })
    }

    /// The buffer of indirect arguments `which`.
    pub fn args(&self, which: ArgsBuffer) -> &wgpu::Buffer {
        match which {
            ArgsBuffer::Apply => &self.apply_args,
            ArgsBuffer::Update => &self.update_args,
        }
    }
}

/// `work`, zeroed but for the semi-implicit CG's constant blocks (m = 0,
/// a = dt² k) where it has them; the implicit integrator overwrites them
/// every step.
fn work_buffer(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    up: &Uploads<'_>,
) -> Result<wgpu::Buffer> {
    let work = zeroed(device, "wgcloth.work", up.work_len * 16);
    if let Some(dt2) = up.constant_blocks {
        let mut blocks = try_vec(up.springs.len(), [0f32; 4], UPLOAD)?;
        for (b, s) in blocks.iter_mut().zip(up.springs) {
            b[3] = dt2 * s.k;
        }
        let at = u64::from(up.params.spring_work_base)
            + u64::from(spring_work::BLOCK) * up.springs.len() as u64;
        queue.write_buffer(&work, at * 16, bytemuck::cast_slice(&blocks));
    }
    Ok(work)
}

/// `status` of `len` words (the status words, then self-collision's
/// bucket counters, zero), with no step found non-finite yet.
fn status_buffer(device: &wgpu::Device, len: u64) -> Result<wgpu::Buffer> {
    let mut words = try_vec(
        usize::try_from(len)
            .unwrap_or(usize::MAX)
            .max(status::COUNT),
        0u32,
        UPLOAD,
    )?;
    words[status::BAD_STEP] = u32::MAX;
    words[status::BAD_PARTICLE] = u32::MAX;
    Ok(init(
        device,
        "wgcloth.status",
        bytemuck::cast_slice(&words),
        STORAGE,
    ))
}

/// `apply_args` and `update_args`, every slot cleared (workgroups 0).
///
/// Each CG iteration's kernels are dispatched indirectly from their slots,
/// which the kernels enable one step ahead and clear behind them, so a
/// stopped CG dispatches no workgroup (see `apply_args` in
/// `shaders/common/cg.wgsl`). A dispatch may not read its arguments from
/// a buffer its kernel binds: cg_apply's slots are in one buffer, enabled
/// by cg_update, which binds it, and cg_update's in the other, enabled by
/// cg_apply; cg_init binds both.
fn indirect_args(device: &wgpu::Device, slots: u32) -> (wgpu::Buffer, wgpu::Buffer) {
    let usage = STORAGE | wgpu::BufferUsages::INDIRECT;
    let cleared: Vec<u32> = (0..args_words(slots) / 3)
        .flat_map(|_| [0u32, 1, 1])
        .collect();
    (
        init(
            device,
            "wgcloth.apply_args",
            bytemuck::cast_slice(&cleared),
            usage,
        ),
        init(
            device,
            "wgcloth.update_args",
            bytemuck::cast_slice(&cleared),
            usage,
        ),
    )
}

/// A bind group of `buffers` at bindings 0, 1, … of `layout` (group 0 of
/// a solver's kernels, and of a batch's).
pub(super) fn buffers_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .zip(0u32..)
        .map(|(b, binding)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}
