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

impl AdapterCost {
    /// The constants of the class of an adapter of `device_type`
    /// (`wgpu::AdapterInfo::device_type`). A CPU adapter (lavapipe, SwiftShader,
    /// WARP) has the constants measured with lavapipe and `cpu_threads`
    /// units (the threads it runs workgroups on: lavapipe's
    /// `LP_NUM_THREADS`, else one per core). The GPU classes' constants are
    /// estimates, not measurements (`docs/performance.md` says how they
    /// were reasoned and what would change them).
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
            // A discrete GPU has 20 to 130 multiprocessors; a dependent
            // dispatch drains the device and launches the next (a few µs);
            // one workgroup of 256 invocations keeps a multiprocessor's
            // lanes a quarter busy, stalled at every barrier.
            wgpu::DeviceType::DiscreteGpu => AdapterCost {
                class: "discrete GPU (estimated)",
                dispatch_us: 4.0,
                units: 64,
                barrier_us: 0.2,
                workgroup_item_us: 0.002,
                dispatch_item_us: 0.001,
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

    #[test]
    fn more_units_than_cloths_take_them_in_one_wave() {
        let cpu = AdapterCost::of(wgpu::DeviceType::Cpu, 4);
        let one = cpu.workgroup_us(&HANGING, 1);
        assert_eq!(cpu.workgroup_us(&HANGING, 4), one);
        assert!(cpu.workgroup_us(&HANGING, 5) > one);
    }
}
