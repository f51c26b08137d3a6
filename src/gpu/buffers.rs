//! A cloth's buffers on the device and the bind groups that hand them to
//! the kernels (group 0: `shaders/common/bindings.wgsl`; group 1 of the
//! kernels that write indirect dispatch arguments: `shaders/common/cg.wgsl`).

use wgpu::util::DeviceExt;

use super::debug::DebugBuffer;
use super::kernel::ArgsGroup;
use super::kernels::GpuKernels;
use super::layout::{GpuParams, GpuSpring};
use crate::budget::try_vec;
use crate::error::Result;
use crate::kernel_config::{partials, spring_work, status, work, WORKGROUP};

/// What the arrays built for upload are named in a memory error.
pub(super) const UPLOAD: &str = "the GPU solver's buffers (their host copies)";

/// What the buffers are made from, built on the host.
pub(super) struct Uploads<'a> {
    /// The uniform block.
    pub params: &'a GpuParams,
    /// A spring per slot.
    pub springs: &'a [GpuSpring],
    /// Adjacency and triangles (see `topo` in
    /// `shaders/common/bindings.wgsl`).
    pub topo: &'a [u32],
    /// Positions and inverse masses, velocities and masses.
    pub x: &'a [[f32; 4]],
    /// Velocities and masses.
    pub v: &'a [[f32; 4]],
    /// Triangle indices.
    pub triangles: &'a [[u32; 3]],
    /// The dense semi-implicit filter (empty without one).
    pub dense: &'a [f32],
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
    pub springs: wgpu::Buffer,
    pub topo: wgpu::Buffer,
    pub x: wgpu::Buffer,
    pub v: wgpu::Buffer,
    pub work: wgpu::Buffer,
    pub spring_work: wgpu::Buffer,
    pub partials: wgpu::Buffer,
    pub status: wgpu::Buffer,
    pub normals: wgpu::Buffer,
    pub dense: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    /// Indirect arguments of the per-particle CG kernels (see
    /// [`ClothBuffers::new`]).
    pub cg_args: wgpu::Buffer,
    /// Indirect arguments of cg_alpha and cg_beta, a slot per recorded CG
    /// iteration.
    pub alpha_slots: wgpu::Buffer,
    pub beta_slots: wgpu::Buffer,
    /// Group 0.
    pub bind_group: wgpu::BindGroup,
    /// Group 0 of the workgroup kernels (on the workgroup path): the
    /// parameters as a cloth table of one.
    pub cloth_group: Option<wgpu::BindGroup>,
    /// Group 1 of cg_start, cg_alpha and cg_beta ([`ArgsGroup::ALL`]
    /// order).
    pub args_groups: [wgpu::BindGroup; 3],
}

/// Usage of the storage buffers: bound, written by the host, read back.
const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::COPY_SRC);

/// The smallest storage buffer made \[bytes\]. A binding must hold at least
/// one element of its array, and a cloth may have no springs (every
/// stiffness zero): an empty array gets one zeroed element of the largest
/// type bound (a `Spring`), which no kernel reads (each stops at its count).
const MIN_BINDING: usize = std::mem::size_of::<GpuSpring>();

/// A buffer holding `contents` (at least [`MIN_BINDING`] bytes).
fn init(
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
        let partial_words = u64::from(partials::SLOTS) * n.div_ceil(u64::from(WORKGROUP))
            + u64::from(partials::CG_SCALARS);
        let params = init(
            device,
            "wgcloth.params",
            bytemuck::bytes_of(up.params),
            uniform,
        );
        let springs = init(
            device,
            "wgcloth.springs",
            bytemuck::cast_slice(up.springs),
            STORAGE,
        );
        let topo = init(
            device,
            "wgcloth.topo",
            bytemuck::cast_slice(up.topo),
            STORAGE,
        );
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
        let work = zeroed(device, "wgcloth.work", u64::from(work::COUNT) * n * 16);
        let spring_work = spring_work_buffer(device, up)?;
        let partials = zeroed(device, "wgcloth.partials", partial_words * 4);
        let status = status_buffer(device);
        let normals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wgcloth.normals"),
            size: (n * 16).max(16),
            usage: vertex,
            mapped_at_creation: false,
        });
        let dense = dense_buffer(device, queue, up);
        let indices = init(
            device,
            "wgcloth.indices",
            bytemuck::cast_slice(up.triangles),
            wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
        );
        let group0 = [
            &params,
            &springs,
            &topo,
            &x,
            &v,
            &work,
            &spring_work,
            &partials,
            &status,
            &normals,
            &dense,
        ];
        let bind_group = buffers_group(device, "wgcloth.bindings", kernels.group0(), &group0);
        let cloth_group = up.workgroup.then(|| {
            buffers_group(
                device,
                "wgcloth.cloth_bindings",
                kernels.cloth_group0(),
                &group0,
            )
        });
        let (cg_args, alpha_slots, beta_slots) = indirect_args(device, up.cg_max_iterations);
        let args_groups = ArgsGroup::ALL.map(|g| {
            let entries: Vec<_> = g
                .bindings()
                .iter()
                .map(|&binding| wgpu::BindGroupEntry {
                    binding,
                    resource: [&cg_args, &alpha_slots, &beta_slots][binding as usize]
                        .as_entire_binding(),
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
            springs,
            topo,
            x,
            v,
            work,
            spring_work,
            partials,
            status,
            normals,
            dense,
            indices,
            cg_args,
            alpha_slots,
            beta_slots,
            bind_group,
            cloth_group,
            args_groups,
        })
    }

    /// The buffer a kernel knows as `buffer`.
    pub fn get(&self, buffer: DebugBuffer) -> &wgpu::Buffer {
        match buffer {
            DebugBuffer::Params => &self.params,
            DebugBuffer::Springs => &self.springs,
            DebugBuffer::Topo => &self.topo,
            DebugBuffer::X => &self.x,
            DebugBuffer::V => &self.v,
            DebugBuffer::Work => &self.work,
            DebugBuffer::SpringWork => &self.spring_work,
            DebugBuffer::Partials => &self.partials,
            DebugBuffer::Status => &self.status,
            DebugBuffer::VertexNormals => &self.normals,
            DebugBuffer::Dense => &self.dense,
            DebugBuffer::CgArgs => &self.cg_args,
            DebugBuffer::AlphaSlots => &self.alpha_slots,
            DebugBuffer::BetaSlots => &self.beta_slots,
        }
    }
}

/// `spring_work`, with the semi-implicit CG's constant blocks (m = 0,
/// a = dt² k) where it has them; the implicit integrator overwrites it
/// every step.
fn spring_work_buffer(device: &wgpu::Device, up: &Uploads<'_>) -> Result<wgpu::Buffer> {
    let mut blocks = try_vec(
        spring_work::COUNT as usize * up.springs.len(),
        [0f32; 4],
        UPLOAD,
    )?;
    if let Some(dt2) = up.constant_blocks {
        for (b, s) in blocks.iter_mut().zip(up.springs) {
            b[3] = dt2 * s.k;
        }
    }
    Ok(init(
        device,
        "wgcloth.spring_work",
        bytemuck::cast_slice(&blocks),
        STORAGE,
    ))
}

/// `status`, with no step found non-finite yet.
fn status_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    let mut words = [0u32; status::COUNT];
    words[status::BAD_STEP] = u32::MAX;
    words[status::BAD_PARTICLE] = u32::MAX;
    init(
        device,
        "wgcloth.status",
        bytemuck::cast_slice(&words),
        STORAGE,
    )
}

/// `dense`, sized for every particle free, so that changing pins (which
/// rebuilds W) never needs a new buffer; a stub without a dense filter.
fn dense_buffer(device: &wgpu::Device, queue: &wgpu::Queue, up: &Uploads<'_>) -> wgpu::Buffer {
    if up.dense.is_empty() {
        return zeroed(device, "wgcloth.dense", 16);
    }
    let n = u64::from(up.params.particle_count);
    let buffer = zeroed(device, "wgcloth.dense", (n * n + n) * 4);
    queue.write_buffer(&buffer, 0, bytemuck::cast_slice(up.dense));
    buffer
}

/// `cg_args`, `alpha_slots` and `beta_slots`.
///
/// The per-particle CG kernels are dispatched indirectly from `cg_args`,
/// which the CG scalar kernels zero when CG stops: a stopped iteration
/// then runs no workgroup. It lives in its own group, bound only to the
/// kernels that write it (a dispatch may not read its arguments from a
/// buffer its kernel binds). cg_start writes the workgroup counts at the
/// start of every solve, before any dispatch reads them (set_cg_args in
/// shaders/common/cg.wgsl is their one formula).
///
/// The scalar kernels' own indirect arguments: a (workgroups, 1, 1) slot
/// per CG iteration, which the kernels enable one ahead and clear behind
/// them (see alpha_slots in shaders/common/cg.wgsl).
fn indirect_args(
    device: &wgpu::Device,
    cg_max_iterations: u32,
) -> (wgpu::Buffer, wgpu::Buffer, wgpu::Buffer) {
    let usage = STORAGE | wgpu::BufferUsages::INDIRECT;
    let cg_args = init(
        device,
        "wgcloth.cg_args",
        bytemuck::cast_slice(&[0u32, 1, 1, 0, 1, 1]),
        usage,
    );
    let slots: Vec<u32> = (0..cg_max_iterations.max(1))
        .flat_map(|_| [0u32, 1, 1])
        .collect();
    let alpha = init(
        device,
        "wgcloth.alpha_slots",
        bytemuck::cast_slice(&slots),
        usage,
    );
    let beta = init(
        device,
        "wgcloth.beta_slots",
        bytemuck::cast_slice(&slots),
        usage,
    );
    (cg_args, alpha, beta)
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
