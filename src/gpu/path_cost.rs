//! The cost model behind the automatic step path (see [`super::path`]):
//! the estimated time of a step on each path, from the adapter's class and
//! the step's work.
//!
//! A step on the multi-dispatch path records `dispatches` dispatches (its
//! plan, [`super::plan`], with [`CG_ITERATIONS_ESTIMATE`] CG iterations)
//! over `items` particles and springs in all; the workgroup path does the
//! same work in one dispatch, inside one workgroup per cloth, a workgroup
//! barrier where the other path has a dispatch. So
//!
//! ```text
//! workgroup      = dispatch + ⌈cloths / units⌉ · (dispatches · barrier + items · workgroup_item)
//! multi-dispatch = cloths · (dispatches · dispatch
//!                            + items · dispatch_item / min(units, ⌈particles / 64⌉))
//! ```
//!
//! — one workgroup runs on one unit (a core of a CPU adapter, a
//! multiprocessor of a GPU) and a batch's cloths fill the units, while a
//! multi-dispatch pass spreads one cloth over every unit its 64-invocation
//! workgroups reach. The constants of each adapter class are in
//! [`AdapterCost::of`]; `docs/performance.md` says where they come from.

use crate::kernel_config::WORKGROUP;

/// CG iterations a step is estimated to take (scenes with the adaptive
/// budget settle at 10 to 40; the choice hardly depends on the number,
/// since every iteration adds dispatches and work to both paths alike).
pub(super) const CG_ITERATIONS_ESTIMATE: u32 = 20;

/// Entries of the dense semi-implicit filter that cost what one item (a
/// particle's or a spring's work) costs: an item loads two or three
/// vectors and does a 3 × 3 block's arithmetic, a filter entry one scalar
/// load and a multiply-add. 16 fits both measured adapters: lavapipe's
/// 33² semi-implicit step on the workgroup path (21.6 ms, model 21.9 ms)
/// and the H200's choice of path at 15² and 33² (docs/performance.md).
pub(super) const DENSE_FILTER_ENTRIES_PER_ITEM: u64 = 16;

/// A step of one cloth, as the cost model sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Work {
    /// Particles.
    pub particles: u64,
    /// Dispatches of a step on the multi-dispatch path: phases between
    /// barriers on the workgroup path.
    pub dispatches: u64,
    /// Particles and springs those dispatches go over, summed (counted in
    /// the general layout, whose kernels take one each): the work of a
    /// step, on either path.
    pub items: u64,
}

/// The constants of an adapter class (see [`AdapterCost::of`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct AdapterCost {
    /// The class, as `--verbose` names it.
    pub class: &'static str,
    /// What a dispatch costs beyond its work: its launch and the barrier
    /// after it \[µs\].
    pub dispatch_us: f64,
    /// Workgroups that run at once.
    pub units: u32,
    /// What a workgroup barrier between two phases of the one-workgroup
    /// kernels costs \[µs\].
    pub barrier_us: f64,
    /// An item's work in the one-workgroup kernels, one workgroup on one
    /// unit \[µs\].
    pub workgroup_item_us: f64,
    /// An item's work in a multi-dispatch pass, per unit \[µs\].
    pub dispatch_item_us: f64,
}

// The CPU class, fitted to lavapipe on this project's 2-vCPU AMD EPYC
// (docs/performance.md, "The automatic step path"): `hanging` (33², 12
// dispatches, 19 274 items a step) steps in 1.3 ms on the multi-dispatch
// path and 4.7 ms on the workgroup path; the per-dispatch latency is the
// bench's (gpu_step, 15² against 33² explicit), the barrier's from a 4 × 4
// cloth, whose work is negligible, on the workgroup path.

/// lavapipe: a dispatch's latency \[µs\].
const CPU_DISPATCH_US: f64 = 25.0;
/// lavapipe: a barrier of the one-workgroup kernels: a switch between the
/// workgroup's 256 invocations each \[µs\].
const CPU_BARRIER_US: f64 = 18.0;
/// lavapipe: an item on the workgroup path \[µs\] — twice a multi-dispatch
/// item's cost per core: the one-workgroup kernels read adjacency lists
/// where the grid kernels gather blocks of particles.
const CPU_WORKGROUP_ITEM_US: f64 = 0.23;
/// lavapipe: an item on the multi-dispatch path, per core \[µs\].
const CPU_DISPATCH_ITEM_US: f64 = 0.104;

// The discrete-GPU class, fitted to an NVIDIA H200 through Vulkan
// (gpu_step bench, the grown `hanging` cloth at 15² and 33², each
// integrator on both paths; docs/performance.md): with these the model
// chooses the faster path in all six cases.

/// H200: a dependent dispatch in one compute pass — the device drains and
/// launches the next: 4.6 µs (explicit, 12 dispatches) to 9 µs (implicit,
/// 286) per dispatch of a 33² step \[µs\].
const GPU_DISPATCH_US: f64 = 6.0;
/// H200: a phase of the one-workgroup kernels: 0.1 µs between the
/// explicit step's phases, about 2 µs between the CG's (each sums over the
/// workgroup in a tree of barriers) \[µs\].
const GPU_BARRIER_US: f64 = 1.0;
/// H200: streaming multiprocessors that each run a cloth's workgroup
/// (132; a batch of 256 `hanging` cloths steps in about twice the time of
/// 64, one of 1 024 in six times).
const GPU_UNITS: u32 = 128;
/// H200: an item on the workgroup path, 256 lanes of one multiprocessor:
/// the explicit step's 15 372 more items at 33² than at 15² cost 61 µs
/// \[µs\].
const GPU_WORKGROUP_ITEM_US: f64 = 0.004;
/// H200: an item on the multi-dispatch path per multiprocessor reached,
/// whose 64-lane workgroups take four times the one-workgroup kernel's
/// 256 lanes' time \[µs\].
const GPU_DISPATCH_ITEM_US: f64 = 0.016;

impl AdapterCost {
    /// The constants of the class of an adapter of `device_type`
    /// (`wgpu::AdapterInfo::device_type`). A CPU adapter (lavapipe, SwiftShader,
    /// WARP) has the constants measured with lavapipe and `cpu_threads`
    /// units (the threads it runs workgroups on: lavapipe's
    /// `LP_NUM_THREADS`, else one per core); a discrete GPU the constants
    /// measured with an NVIDIA H200; the other GPU classes' constants are
    /// estimates, not measurements (`docs/performance.md` says how each
    /// was found).
    pub fn of(device_type: wgpu::DeviceType, cpu_threads: u32) -> AdapterCost {
        match device_type {
            wgpu::DeviceType::Cpu => AdapterCost {
                class: "CPU adapter (measured with lavapipe)",
                dispatch_us: CPU_DISPATCH_US,
                units: cpu_threads.max(1),
                barrier_us: CPU_BARRIER_US,
                workgroup_item_us: CPU_WORKGROUP_ITEM_US,
                dispatch_item_us: CPU_DISPATCH_ITEM_US,
            },
            // Fitted to an NVIDIA H200 (Vulkan; docs/performance.md, "The
            // automatic step path"): see the constants' comments.
            wgpu::DeviceType::DiscreteGpu => AdapterCost {
                class: "discrete GPU (measured with an NVIDIA H200)",
                dispatch_us: GPU_DISPATCH_US,
                units: GPU_UNITS,
                barrier_us: GPU_BARRIER_US,
                workgroup_item_us: GPU_WORKGROUP_ITEM_US,
                dispatch_item_us: GPU_DISPATCH_ITEM_US,
            },
            // An integrated or virtual GPU, or one the driver does not
            // classify: fewer units, slower launches.
            wgpu::DeviceType::IntegratedGpu
            | wgpu::DeviceType::VirtualGpu
            | wgpu::DeviceType::Other => AdapterCost {
                class: "integrated GPU (estimated)",
                dispatch_us: 10.0,
                units: 8,
                barrier_us: 0.5,
                workgroup_item_us: 0.01,
                dispatch_item_us: 0.005,
            },
        }
    }

    /// Estimated time of a step of `cloths` cloths of `work` each on the
    /// workgroup path, one dispatch for all \[µs\].
    pub fn workgroup_us(&self, work: &Work, cloths: u32) -> f64 {
        let waves = cloths.div_ceil(self.units.max(1)).max(1);
        let one =
            work.dispatches as f64 * self.barrier_us + work.items as f64 * self.workgroup_item_us;
        self.dispatch_us + f64::from(waves) * one
    }

    /// Estimated time of a step of `cloths` cloths of `work` each on the
    /// multi-dispatch path, each its own dispatches \[µs\].
    pub fn multi_dispatch_us(&self, work: &Work, cloths: u32) -> f64 {
        let groups = work.particles.div_ceil(u64::from(WORKGROUP)).max(1);
        let spread = groups.min(u64::from(self.units.max(1)));
        let one = work.dispatches as f64 * self.dispatch_us
            + work.items as f64 * self.dispatch_item_us / spread as f64;
        f64::from(cloths.max(1)) * one
    }
}

/// The threads a CPU adapter runs workgroups on: lavapipe's
/// `LP_NUM_THREADS` where set to a number, else the host's cores.
pub(super) fn cpu_threads() -> u32 {
    std::env::var("LP_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<u32>().ok())
        .filter(|&n| n > 0)
        .or_else(|| {
            std::thread::available_parallelism()
                .ok()
                .and_then(|n| u32::try_from(n.get()).ok())
        })
        .unwrap_or(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `hanging`'s step on the multi-dispatch path (33 × 33 particles,
    /// 10 fix-up passes): what `--verbose` reports.
    const HANGING: Work = Work {
        particles: 1089,
        dispatches: 13,
        items: 19_000,
    };

    #[test]
    fn a_lone_cloth_on_two_cores_is_faster_spread_over_both() {
        let cpu = AdapterCost::of(wgpu::DeviceType::Cpu, 2);
        assert!(cpu.multi_dispatch_us(&HANGING, 1) < cpu.workgroup_us(&HANGING, 1));
    }

    #[test]
    fn many_small_cloths_are_faster_sharing_one_dispatch() {
        let small = Work {
            particles: 81,
            dispatches: 13,
            items: 1_500,
        };
        for class in [
            wgpu::DeviceType::Cpu,
            wgpu::DeviceType::DiscreteGpu,
            wgpu::DeviceType::IntegratedGpu,
        ] {
            let cost = AdapterCost::of(class, 2);
            assert!(
                cost.workgroup_us(&small, 64) < cost.multi_dispatch_us(&small, 64),
                "{class:?}"
            );
        }
    }

    #[test]
    fn a_gpu_steps_a_small_lone_cloth_in_one_dispatch_and_a_large_one_spread() {
        let gpu = AdapterCost::of(wgpu::DeviceType::DiscreteGpu, 2);
        let tiny = Work {
            particles: 64,
            dispatches: 13,
            items: 1_000,
        };
        assert!(gpu.workgroup_us(&tiny, 1) < gpu.multi_dispatch_us(&tiny, 1));
        let large = Work {
            particles: 4096,
            dispatches: 13,
            items: 72_000,
        };
        assert!(gpu.multi_dispatch_us(&large, 1) < gpu.workgroup_us(&large, 1));
    }

    /// The H200 measurement the discrete-GPU class is fitted to: the
    /// grown `hanging` cloth's steps (their work as `--verbose` reports
    /// it) and the path that stepped each faster (gpu_step bench, one
    /// run: multi-dispatch against workgroup, µs per step).
    #[test]
    fn the_discrete_gpu_class_chooses_the_path_the_h200_measured_faster() {
        let gpu = AdapterCost::of(wgpu::DeviceType::DiscreteGpu, 2);
        let work = |particles, dispatches, items| Work {
            particles,
            dispatches,
            items,
        };
        // (case, work, workgroup measured faster)
        let cases = [
            ("15² explicit, 67 vs 23", work(225, 12, 3_902), true),
            ("15² implicit, 1518 vs 580", work(225, 86, 9_690), true),
            ("15² semi-implicit, 207 vs 172", work(225, 14, 7_235), true),
            ("33² explicit, 55 vs 84", work(1089, 12, 19_274), false),
            ("33² implicit, 2560 vs 1828", work(1089, 86, 37_369), true),
            (
                "33² semi-implicit, 385 vs 1749",
                work(1089, 14, 94_211),
                false,
            ),
        ];
        for (case, w, workgroup_faster) in cases {
            let chose_workgroup = gpu.workgroup_us(&w, 1) < gpu.multi_dispatch_us(&w, 1);
            assert_eq!(chose_workgroup, workgroup_faster, "{case}");
        }
    }

    #[test]
    fn more_units_than_cloths_take_them_in_one_wave() {
        let cpu = AdapterCost::of(wgpu::DeviceType::Cpu, 4);
        let one = cpu.workgroup_us(&HANGING, 1);
        assert_eq!(cpu.workgroup_us(&HANGING, 4), one);
        assert!(cpu.workgroup_us(&HANGING, 5) > one);
    }
}
