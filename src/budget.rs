//! What a scene needs in memory, on the host and on the GPU device,
//! computed from its sizes alone before anything is allocated; what the
//! host can give. (The crate's own fallible allocation for what a scene's
//! size decides lives here too, crate-private.)
//!
//! Every constructor whose allocations grow with the input —
//! [`Model::new`](crate::model::Model::new),
//! [`CpuSolver::new`](crate::cpu::CpuSolver::new),
//! [`GpuSolver::new`](crate::gpu::GpuSolver::new) and
//! [`render_scene`](crate::render::render_scene) — first adds up what it
//! will hold and refuses with [`Error::OutOfMemory`] (the amount, the limit
//! and what needs it) when that cannot fit. The estimates count the large,
//! size-dependent arrays (a few dozen bytes per particle and spring, the
//! dense filter's `n²` entries, an image's pixels), each from the type it
//! is stored as, so they stay right when a type changes; fixed overheads
//! (a few kilobytes) are left out.
//!
//! The host's limit ([`host_limit`], Linux only; elsewhere nothing is
//! checked) is the smallest of `MemAvailable` in `/proc/meminfo` and the
//! room left under the soft `Max address space` and `Max data size` rows of
//! `/proc/self/limits` (`ulimit -v`, `ulimit -d`) when those are not
//! unlimited. On a CPU adapter (Mesa's lavapipe) device memory is host
//! memory, so device buffers count against the host's limit too (see
//! [`host_need`]).

use std::fmt;
use std::mem::size_of;

use crate::cpu::filter::FilterSystem;
use crate::cpu::implicit::{Filter, SpringBlock};
use crate::cpu::mat3::Sym3;
use crate::cpu::{SpringR, REDUCTION_BLOCK};
use crate::error::{Error, Result};
use crate::gpu::layout::{self, section, GpuParams, GpuSpring};
use crate::model::{Model, Spring};
use crate::params::Params;
use crate::real::{Real, Vec3};

/// A byte count shown to a user: binary units with one decimal, then the
/// exact count (`7.3 TiB (7999968000032 bytes)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bytes(pub u64);

impl Bytes {
    /// For `thiserror` messages, which see fields by reference.
    pub fn of(bytes: &u64) -> Bytes {
        Bytes(*bytes)
    }
}

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
        if self.0 < 1024 {
            return write!(f, "{} bytes", self.0);
        }
        let mut value = self.0 as f64 / 1024.0;
        let mut unit = 0;
        while value >= 1024.0 && unit + 1 < UNITS.len() {
            value /= 1024.0;
            unit += 1;
        }
        write!(f, "{value:.1} {} ({} bytes)", UNITS[unit], self.0)
    }
}

/// How much more the host can allocate, and which limit says so.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostLimit {
    /// Bytes that can still be allocated.
    pub available: u64,
    /// Which limit that is, for messages (`MemAvailable in /proc/meminfo`).
    pub source: &'static str,
}

/// The host's room for new allocations now (see the module docs), or
/// `None` where it cannot be read (other operating systems), in which case
/// nothing is refused up front.
pub fn host_limit() -> Option<HostLimit> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let mut best = HostLimit {
        available: kib_field(&meminfo, "MemAvailable:")?,
        source: "MemAvailable in /proc/meminfo",
    };
    let limits = std::fs::read_to_string("/proc/self/limits").unwrap_or_default();
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    for (row, used, source) in [
        (
            "Max address space",
            "VmSize:",
            "the address-space limit (ulimit -v) less what the process maps",
        ),
        (
            "Max data size",
            "VmData:",
            "the data-size limit (ulimit -d) less what the process uses",
        ),
    ] {
        let Some(soft) = soft_limit(&limits, row) else {
            continue;
        };
        let room = soft.saturating_sub(kib_field(&status, used).unwrap_or(0));
        if room < best.available {
            best = HostLimit {
                available: room,
                source,
            };
        }
    }
    Some(best)
}

/// A `NAME:   123 kB` row of `/proc/meminfo` or `/proc/self/status`, in
/// bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// The soft limit of a `/proc/self/limits` row in bytes; `None` when it is
/// unlimited or missing.
fn soft_limit(limits: &str, row: &str) -> Option<u64> {
    let line = limits.lines().find(|l| l.starts_with(row))?;
    line[row.len()..].split_whitespace().next()?.parse().ok()
}

/// Refuses `needed` bytes of host memory for `what` when the host cannot
/// give them (see [`host_limit`]); `what` is built only then.
pub fn check_host(needed: u64, what: impl FnOnce() -> String) -> Result<()> {
    match host_limit() {
        Some(limit) if needed > limit.available => Err(Error::OutOfMemory {
            what: what(),
            needed,
            available: Some(limit.available),
            limit: format!(
                "the host has {} available ({})",
                Bytes(limit.available),
                limit.source
            ),
        }),
        _ => Ok(()),
    }
}

/// Host bytes kept free besides the estimates on a CPU adapter: Mesa's
/// lavapipe compiles each kernel with LLVM in host memory, which no
/// estimate here counts, and when the address space runs short there it
/// crashes (a segfault inside the driver, under `ulimit -v`) instead of
/// reporting an error. A 600 × 600 explicit cloth, whose buffers the
/// estimate puts at 0.7 GiB, crashed with 0.9 GiB of address space left
/// and ran with 1.2 GiB; half a gibibyte covers that gap with room over.
pub const CPU_ADAPTER_RESERVE: u64 = 512 << 20;

/// Host bytes a GPU workload of `host` host bytes and `device` device
/// bytes needs on `device`'s host: on a CPU adapter (lavapipe) device
/// memory is host memory, and [`CPU_ADAPTER_RESERVE`] is kept free.
pub fn host_need(device: &wgpu::Device, host: u64, device_bytes: u64) -> u64 {
    if device.adapter_info().device_type == wgpu::DeviceType::Cpu {
        total(&[host, device_bytes, CPU_ADAPTER_RESERVE])
    } else {
        host
    }
}

/// Refuses a GPU workload of `host` host bytes and `device_bytes` device
/// bytes on `device` when its host cannot give [`host_need`]'s bytes (see
/// [`check_host`]). On a CPU adapter the message says which part is the
/// workload's own and which [`CPU_ADAPTER_RESERVE`] the driver's kernel
/// compiler is kept: the reserve is not the cloth's need.
pub fn check_gpu_host(
    device: &wgpu::Device,
    host: u64,
    device_bytes: u64,
    what: impl FnOnce() -> String,
) -> Result<()> {
    let needed = host_need(device, host, device_bytes);
    let own = total(&[host, device_bytes]);
    check_host(needed, || {
        let what = what();
        if needed > own {
            format!(
                "{what} ({} of its own, plus the driver's reserve of {} that a CPU \
                 adapter keeps free for compiling kernels)",
                Bytes(own),
                Bytes(needed - own)
            )
        } else {
            what
        }
    })
}

/// The error of an allocation the allocator refused.
fn refused<T>(len: usize, what: &str) -> Error {
    Error::OutOfMemory {
        what: what.to_string(),
        needed: (len as u64).saturating_mul(size_of::<T>() as u64),
        available: None,
        limit: "the allocator refused it".into(),
    }
}

/// `Vec::with_capacity(len)`, failing with [`Error::OutOfMemory`] naming
/// `what` instead of aborting when the memory is not there.
pub(crate) fn try_with_capacity<T>(len: usize, what: &str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| refused::<T>(len, what))?;
    Ok(v)
}

/// `vec![value; len]`, failing like [`try_with_capacity`].
pub(crate) fn try_vec<T: Clone>(len: usize, value: T, what: &str) -> Result<Vec<T>> {
    let mut v = try_with_capacity(len, what)?;
    v.resize(len, value);
    Ok(v)
}

/// `items.collect()`, reserving first and failing like
/// [`try_with_capacity`].
pub(crate) fn try_collect<T>(
    items: impl ExactSizeIterator<Item = T>,
    what: &str,
) -> Result<Vec<T>> {
    let mut v = try_with_capacity(items.len(), what)?;
    v.extend(items);
    Ok(v)
}

/// `count × size_of::<T>()`, saturating (the sizes come from input).
pub(crate) fn array<T>(count: u64) -> u64 {
    count.saturating_mul(size_of::<T>() as u64)
}

/// Sum of byte counts, saturating.
fn total(parts: &[u64]) -> u64 {
    parts.iter().fold(0u64, |a, &b| a.saturating_add(b))
}

/// The sizes the estimates are computed from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counts {
    /// Particles.
    pub particles: u64,
    /// Springs.
    pub springs: u64,
    /// Triangles.
    pub triangles: u64,
    /// Particles that are not pinned (the semi-implicit filter's size).
    pub free: u64,
    /// Entries of the linear bending operator's rows (0 without one).
    pub bending: u64,
}

impl Counts {
    /// The counts of a built model.
    pub fn of_model(model: &Model) -> Counts {
        Counts {
            particles: model.particle_count() as u64,
            springs: model.springs.len() as u64,
            triangles: model.triangles.len() as u64,
            free: (model.particle_count() - model.pinned_count()) as u64,
            bending: model.bending.as_ref().map_or(0, |b| b.columns.len() as u64),
        }
    }
}

/// Host bytes a [`Model`] of these counts holds, plus what
/// [`Model::new`] holds while building it (each kind's particle pairs, the
/// adjacency's cursor and the stable sort's buffer of half the springs).
pub fn model_bytes(particles: u64, springs: u64, triangles: u64) -> u64 {
    let adjacency =
        |entries: u64| array::<u32>(particles + 1).saturating_add(array::<u32>(entries));
    total(&[
        array::<[f64; 3]>(particles),
        array::<f64>(particles),
        array::<bool>(particles),
        array::<Spring>(springs),
        array::<[u32; 3]>(triangles),
        adjacency(2 * springs),
        adjacency(3 * triangles),
        // Transients of `Model::new`.
        array::<(u32, u32)>(springs),
        array::<u32>(particles + 1),
        array::<Spring>(springs / 2),
    ])
}

/// Host bytes of the semi-implicit filter's assembly and factor in
/// precision `R`: the sparse system, the banded Cholesky factor (always
/// `f64`, `free × (bandwidth + 1)`), and either the dense inverse
/// (`free²` entries) or the factor's copy in `R`.
pub fn filter_bytes<R: Real>(counts: Counts, bandwidth: u64, dense: bool) -> u64 {
    let (n, free) = (counts.particles, counts.free);
    let band = free.saturating_mul(bandwidth + 1);
    let system = total(&[
        array::<u32>(free),
        array::<f64>(free),
        array::<(u32, u32, f64)>(counts.springs),
        // The particle order and each particle's filter position.
        array::<u32>(2 * n),
    ]);
    let held = if dense {
        total(&[
            array::<R>(free.saturating_mul(free)),
            // The unit vector and the column of each solve.
            array::<Vec3<f64>>(2 * free),
        ])
    } else {
        array::<R>(band)
    };
    total(&[system, array::<f64>(band), held, array::<Vec3<R>>(free)])
}

/// Bytes of the linear bending operator's rows in precision `R`: offsets,
/// columns and coefficients (none without one).
fn bending_bytes<R>(counts: Counts) -> u64 {
    if counts.bending == 0 {
        return 0;
    }
    total(&[
        array::<u32>(counts.particles + 1),
        array::<u32>(counts.bending),
        array::<R>(counts.bending),
    ])
}

/// Host bytes of a [`CpuSolver`](crate::cpu::CpuSolver) in precision `R`
/// besides its filter: the system in `R`, the state and the workspace.
pub fn cpu_solver_bytes<R: Real>(counts: Counts) -> u64 {
    let Counts {
        particles: n,
        springs: s,
        triangles: t,
        ..
    } = counts;
    let system = total(&[
        array::<SpringR<R>>(s),
        array::<R>(s),
        array::<u32>(n + 1),
        array::<u32>(2 * s),
        array::<[u32; 3]>(t),
        array::<u32>(n + 1),
        array::<u32>(3 * t),
        array::<R>(2 * n),
        bending_bytes::<R>(counts),
    ]);
    // Positions and velocities; eleven per-particle vectors of the
    // workspace (force … z), its CG terms (three per particle) and its
    // per-spring and per-triangle ones.
    let state = array::<Vec3<R>>(2 * n);
    let workspace = total(&[
        array::<Vec3<R>>(11 * n),
        array::<R>(3 * n),
        array::<Vec3<R>>(2 * s),
        array::<bool>(s),
        array::<Vec3<R>>(t),
        array::<Filter<R>>(n),
        array::<Sym3<R>>(n),
        array::<SpringBlock<R>>(s),
    ]);
    total(&[system, state, workspace])
}

/// What a [`GpuSolver`](crate::gpu::GpuSolver) needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuNeed {
    /// Device bytes: every buffer the solver creates.
    pub device: u64,
    /// Host bytes held while building and reading back: the model's copy,
    /// the arrays uploaded, and the dense filter's host build.
    pub host: u64,
    /// The largest single buffer \[bytes\].
    pub largest: u64,
}

/// What a GPU solver of `counts` with `slots` spring slots (the springs,
/// or six per particle in grid layout) needs; `dense`: with the dense
/// semi-implicit filter, whose factor has this `bandwidth`.
pub fn gpu_bytes(
    counts: Counts,
    slots: u64,
    params: &Params,
    dense: bool,
    bandwidth: u64,
) -> GpuNeed {
    let Counts {
        particles: n,
        triangles: t,
        ..
    } = counts;
    let vec4 = |count: u64| array::<[f32; 4]>(count);
    let topo = array::<u32>(total(&[2 * (n + 1), 4 * counts.springs, 3 * t, 3 * t]));
    let springs = array::<GpuSpring>(slots);
    let spring_work = vec4(u64::from(layout::SPRING_SECTIONS) * slots);
    let work = vec4(u64::from(section::COUNT) * n);
    // Sized for every particle free (pins may change); built for the free
    // ones.
    let dense_buffer = if dense {
        array::<f32>(n.saturating_mul(n).saturating_add(n))
    } else {
        0
    };
    // A partial per `vec4` (see `partial` in shaders/common/layout.wgsl).
    let partials = vec4(
        u64::from(layout::PARTIAL_SLOTS) * n.div_ceil(REDUCTION_BLOCK as u64)
            + u64::from(layout::CG_SCALARS),
    );
    // The two buffers the kernels bind: read-only model data, scratch.
    let grids = array::<u32>(crate::gpu::build::mesh_grid_words(&params.mesh_colliders));
    // Self-collision's rest positions and their seam partners'.
    let rest = if params.self_collision.is_some() {
        vec4(2 * n)
    } else {
        0
    };
    let model = total(&[
        springs,
        topo,
        dense_buffer,
        grids,
        rest,
        bending_bytes::<f32>(counts),
    ]);
    let scratch = total(&[work, spring_work, partials]);
    // A slot of apply_args and one of update_args per recorded CG
    // iteration, and one more.
    let slot_words = array::<[u32; 3]>(
        2 * (u64::from(
            params
                .implicit
                .max_iterations
                .max(crate::gpu::FILTER_CG_MAX_ITERATIONS),
        ) + 1),
    );
    let device = total(&[
        size_of::<GpuParams>() as u64,
        model,
        // Positions, velocities and normals.
        vec4(3 * n),
        scratch,
        array::<[u32; 3]>(t),
        slot_words,
        // A read-back of positions and velocities.
        vec4(2 * n),
    ]);
    // The f32 inverse, and the words uploaded (its transpose).
    let dense_build = if dense {
        let free = counts.free;
        filter_bytes::<f32>(counts, bandwidth, true)
            .saturating_add(array::<f32>(free.saturating_mul(free).saturating_add(free)))
    } else {
        0
    };
    let host = total(&[
        model_bytes(n, counts.springs, t),
        // The model's arrays built, then packed into one upload with the
        // dense filter's words.
        2 * (topo + springs),
        if dense {
            array::<f32>(
                counts
                    .free
                    .saturating_mul(counts.free)
                    .saturating_add(counts.free),
            )
        } else {
            0
        },
        spring_work,
        vec4(2 * n),
        // The read-back's bytes and the state unpacked from them.
        vec4(2 * n),
        array::<Vec3<f32>>(2 * n),
        dense_build,
    ]);
    GpuNeed {
        device,
        host,
        largest: model.max(scratch).max(vec4(n)),
    }
}

/// The bandwidth bound the filter estimates use: the largest distance in
/// filter order between a spring's ends, pins counted (leaving pinned
/// particles out of the order only brings ends closer).
pub fn filter_bandwidth(model: &Model) -> u64 {
    let grid = model.grid.as_ref().map(|g| (g.nx, g.ny));
    model
        .springs
        .iter()
        .map(|s| {
            let (a, b) = (
                FilterSystem::rank(s.i as usize, grid),
                FilterSystem::rank(s.j as usize, grid),
            );
            a.abs_diff(b) as u64
        })
        .max()
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_read_as_a_user_expects() {
        assert_eq!(Bytes(1000).to_string(), "1000 bytes");
        assert_eq!(Bytes(1536).to_string(), "1.5 KiB (1536 bytes)");
        assert_eq!(
            Bytes(8 << 40).to_string(),
            format!("8.0 TiB ({} bytes)", 8u64 << 40)
        );
    }

    #[test]
    fn proc_rows_parse_and_unlimited_is_no_limit() {
        let meminfo = "MemTotal:       24684084 kB\nMemAvailable:   1000 kB\n";
        assert_eq!(kib_field(meminfo, "MemAvailable:"), Some(1_024_000));
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max data size             unlimited            unlimited            bytes\n\
                      Max address space         1048576000           unlimited            bytes\n";
        assert_eq!(soft_limit(limits, "Max data size"), None);
        assert_eq!(soft_limit(limits, "Max address space"), Some(1_048_576_000));
    }

    #[test]
    fn a_refused_allocation_is_an_error_naming_what_and_how_much() {
        let err = try_vec(usize::MAX / 2, 0u8, "a test array").expect_err("too big");
        let msg = err.to_string();
        assert!(msg.contains("a test array"), "{msg}");
        assert!(msg.contains(&(usize::MAX / 2).to_string()), "{msg}");
        assert_eq!(try_vec(3, 7u16, "small").ok(), Some(vec![7, 7, 7]));
    }

    #[test]
    fn the_dense_filter_grows_with_the_square_of_the_free_particles() {
        let counts = |free| Counts {
            particles: free,
            springs: 3 * free,
            triangles: 2 * free,
            free,
            bending: 0,
        };
        let small = filter_bytes::<f64>(counts(1000), 4, true);
        let big = filter_bytes::<f64>(counts(1_000_000), 4, true);
        assert!(small >= 1000 * 1000 * 8, "{small}");
        assert!(big >= 1_000_000u64 * 1_000_000 * 8, "{big}");
        assert!(filter_bytes::<f64>(counts(1_000_000), 4, false) < 1 << 30);
    }
}
