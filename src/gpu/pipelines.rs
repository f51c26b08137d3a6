//! Compute pipelines: one per kernel variant, built once from the host's
//! device and cached by the scene features they are specialised for.
//!
//! A variant is a kernel (`shaders/NAME.wgsl`) plus `override` constants:
//! the workgroup size, the features (`HAS_WIND`, `HAS_GROUND`,
//! `HAS_SPHERES` — code of an absent feature is compiled out), and
//! per-kernel constants such as the fix-up's source and destination
//! sections. Switching a scene's features back and forth costs one compile
//! per new variant, then nothing.

use std::collections::hash_map::Entry;
use std::collections::HashMap;

use super::grid::GridBlock;
use super::layout::section;
use super::shaders;
use super::WORKGROUP;
use crate::error::{Error, Result};
use crate::params::Integrator;

/// Scene features a pipeline variant is specialised for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Features {
    /// Wind on triangles.
    pub wind: bool,
    /// A ground plane.
    pub ground: bool,
    /// At least one sphere.
    pub spheres: bool,
    /// Some particle can be constrained in CG (pins or colliders).
    pub filter: bool,
    /// Some spring is damped.
    pub damping: bool,
    /// The springs are in grid layout (see `gpu/grid.rs`): gather by row
    /// and column.
    pub grid: bool,
    /// Particles per invocation of the grid gather kernels
    /// ([`GridBlock::ONE`] without grid layout).
    pub block: GridBlock,
    /// The implicit CG's coarse levels (`cpu/coarse.rs`).
    pub coarse: bool,
}

/// Invocations of the one-workgroup CG scalar kernels (cg_start, cg_alpha,
/// cg_beta) on devices that allow it (see [`sum_group`]).
pub const SUM_GROUP: u32 = 256;

/// The scalar kernels' workgroup size on a device with `limits`:
/// [`SUM_GROUP`], or the largest workgroup the device allows. Each scalar
/// kernel sums a term per particle as the CPU mirror does — block sums of
/// [`WORKGROUP`] particles, then the block sums in sequence — with its
/// invocations sharing the blocks and the block sums staged through
/// workgroup memory before invocation 0 adds them (`sum_w` in
/// `shaders/common/cg.wgsl`). The same order, so the same bits, for every
/// width. Wide because on a GPU a workgroup of [`WORKGROUP`] with
/// invocation 0 loading a 257² cloth's ~1000 block sums one by one from
/// storage would be bound by memory latency (reasoned from the arithmetic).
/// A CPU adapter gains nothing from the width and loses little (the staging
/// barriers), so every adapter runs the same form: the code CI runs is the
/// code a GPU runs.
pub fn sum_group(limits: &wgpu::Limits) -> u32 {
    SUM_GROUP
        .min(limits.max_compute_invocations_per_workgroup)
        .min(limits.max_compute_workgroup_size_x)
}

/// One kernel variant: entry point, name suffix, extra constants.
struct Variant {
    entry: &'static str,
    suffix: &'static str,
    constants: &'static [(&'static str, f64)],
}

const fn v(
    entry: &'static str,
    suffix: &'static str,
    constants: &'static [(&'static str, f64)],
) -> Variant {
    Variant {
        entry,
        suffix,
        constants,
    }
}

const PRED: f64 = section::X_PRED as f64;
const SNAPSHOT: f64 = section::SNAPSHOT as f64;
/// `STATE_BUFFERS` in the kernels: read or write x and v.
const STATE_BUFFERS: f64 = u32::MAX as f64;
const ALT: f64 = section::X_ALT as f64;

/// Fix-up and step end, shared by explicit and semi-implicit. Pass k of a
/// step is variant `k mod 6` (ping-pong parity × flag slot mod 3); pass 0
/// has its own variant, which does not look for a previous pass.
const FIXUP: &[Variant] = &[
    v(
        "fixup_jacobi",
        ".first",
        &[("SRC", PRED), ("DST", ALT), ("FLAG", 0.0), ("FIRST", 1.0)],
    ),
    v(
        "fixup_jacobi",
        ".1",
        &[("SRC", ALT), ("DST", PRED), ("FLAG", 1.0), ("FIRST", 0.0)],
    ),
    v(
        "fixup_jacobi",
        ".2",
        &[("SRC", PRED), ("DST", ALT), ("FLAG", 2.0), ("FIRST", 0.0)],
    ),
    v(
        "fixup_jacobi",
        ".3",
        &[("SRC", ALT), ("DST", PRED), ("FLAG", 0.0), ("FIRST", 0.0)],
    ),
    v(
        "fixup_jacobi",
        ".4",
        &[("SRC", PRED), ("DST", ALT), ("FLAG", 1.0), ("FIRST", 0.0)],
    ),
    v(
        "fixup_jacobi",
        ".5",
        &[("SRC", ALT), ("DST", PRED), ("FLAG", 2.0), ("FIRST", 0.0)],
    ),
    v(
        "fixup_jacobi",
        ".0",
        &[("SRC", PRED), ("DST", ALT), ("FLAG", 0.0), ("FIRST", 0.0)],
    ),
    v("finish_step", "", &[]),
];

/// The fix-up variant of pass `k`.
pub fn fixup_variant(k: u32) -> &'static str {
    const NAMES: [&str; 6] = [
        "fixup_jacobi.0",
        "fixup_jacobi.1",
        "fixup_jacobi.2",
        "fixup_jacobi.3",
        "fixup_jacobi.4",
        "fixup_jacobi.5",
    ];
    if k == 0 {
        "fixup_jacobi.first"
    } else {
        NAMES[(k % 6) as usize]
    }
}

/// The kernels that write the CG kernels' indirect dispatch arguments,
/// each with a group 1 of its own (see `alpha_slots` in
/// `shaders/common/cg.wgsl`).
pub const ARGS_WRITERS: [&str; 3] = ["cg_start", "cg_alpha", "cg_beta"];

/// CG, shared by implicit and the scalable semi-implicit filter.
const CG: &[Variant] = &[
    v("cg_init", "", &[]),
    v("cg_start", "", &[]),
    v("cg_apply", "", &[]),
    v("cg_alpha", "", &[]),
    v("cg_update", "", &[]),
    v("cg_beta", "", &[]),
];

const EXPLICIT: &[Variant] = &[
    v("spring_forces", "", &[]),
    v("explicit_integrate", "", &[]),
    v("explicit_integrate", ".fused", &[("FUSED", 1.0)]),
    v(
        "explicit_integrate",
        ".to_snapshot",
        &[
            ("FUSED", 1.0),
            ("SNAP_IN", STATE_BUFFERS),
            ("SNAP_OUT", SNAPSHOT),
        ],
    ),
    v(
        "explicit_integrate",
        ".from_snapshot",
        &[
            ("FUSED", 1.0),
            ("SNAP_IN", SNAPSHOT),
            ("SNAP_OUT", STATE_BUFFERS),
        ],
    ),
    v("explicit_seed", "", &[("SNAP", SNAPSHOT)]),
];

const IMPLICIT: &[Variant] = &[
    v("implicit_springs", "", &[]),
    v("implicit_prepare", "", &[]),
    v("coarse_setup", "", &[]),
    v("cg_update", ".first", &[("FIRST", 1.0)]),
    v("cg_prolong", "", &[]),
    v("implicit_finish", "", &[]),
];

const SEMI: &[Variant] = &[
    v("spring_forces", "", &[]),
    v("semi_rhs", "", &[]),
    v("semi_rhs", ".keep", &[("ZERO_DV", 0.0)]),
    v("filter_dense", "", &[]),
    v("semi_cg_prepare", "", &[]),
    v("torque_centre", "", &[]),
    v("torque_moments", "", &[]),
    v("torque_apply", "", &[]),
    v("semi_integrate", "", &[]),
];

const RENDER: &[Variant] = &[v("normals", "", &[])];

/// The variants an integrator records.
fn variants(integrator: Integrator) -> impl Iterator<Item = &'static Variant> {
    let groups: &[&[Variant]] = match integrator {
        Integrator::Explicit => &[EXPLICIT, FIXUP, RENDER],
        Integrator::Implicit => &[IMPLICIT, CG, RENDER],
        Integrator::SemiImplicit => &[SEMI, CG, FIXUP, RENDER],
    };
    groups.iter().flat_map(|g| g.iter())
}

/// The pipelines of one solver.
#[derive(Debug)]
pub struct Pipelines {
    layout: wgpu::PipelineLayout,
    /// With the CG dispatch arguments as group 1, one per entry of
    /// [`ARGS_WRITERS`].
    args_layouts: [wgpu::PipelineLayout; 3],
    modules: HashMap<(&'static str, GridBlock), wgpu::ShaderModule>,
    cache: HashMap<(String, Features), wgpu::ComputePipeline>,
}

impl Pipelines {
    /// An empty cache for pipelines of `layout` (`args_layouts` for the
    /// kernels that write the CG dispatch arguments, in [`ARGS_WRITERS`]
    /// order).
    pub fn new(layout: wgpu::PipelineLayout, args_layouts: [wgpu::PipelineLayout; 3]) -> Self {
        Pipelines {
            layout,
            args_layouts,
            modules: HashMap::new(),
            cache: HashMap::new(),
        }
    }

    /// Builds every variant `integrator` records for `features` that is not
    /// cached yet.
    pub fn ensure(
        &mut self,
        device: &wgpu::Device,
        integrator: Integrator,
        features: Features,
    ) -> Result<()> {
        let sum_threads = f64::from(sum_group(&device.limits()));
        for variant in variants(integrator) {
            let name = format!("{}{}", variant.entry, variant.suffix);
            if self.cache.contains_key(&(name.clone(), features)) {
                continue;
            }
            let module = match self.modules.entry((variant.entry, features.block)) {
                Entry::Occupied(e) => e.into_mut(),
                Entry::Vacant(e) => {
                    let source = shaders::kernel_source(variant.entry, features.block)
                        .map_err(Error::Gpu)?;
                    e.insert(device.create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some(&format!("wgcloth.{}", variant.entry)),
                        source: wgpu::ShaderSource::Wgsl(source.into()),
                    }))
                }
            };
            let flag = |on: bool| f64::from(u8::from(on));
            let mut constants: Vec<(&str, f64)> = vec![
                ("WORKGROUP", f64::from(WORKGROUP)),
                ("HAS_WIND", flag(features.wind)),
                ("HAS_GROUND", flag(features.ground)),
                ("HAS_SPHERES", flag(features.spheres)),
                ("HAS_FILTER", flag(features.filter)),
                ("HAS_DAMPING", flag(features.damping)),
                ("GRID", flag(features.grid)),
                (
                    "CONSTANT_BLOCKS",
                    flag(integrator == Integrator::SemiImplicit),
                ),
                ("COARSE", flag(features.coarse)),
                ("SUM_GROUP", sum_threads),
            ];
            constants.extend_from_slice(variant.constants);
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&format!("wgcloth.{name}")),
                layout: Some(
                    match ARGS_WRITERS.iter().position(|&w| w == variant.entry) {
                        Some(k) => &self.args_layouts[k],
                        None => &self.layout,
                    },
                ),
                module,
                entry_point: Some(variant.entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            });
            self.cache.insert((name, features), pipeline);
        }
        Ok(())
    }

    /// The pipeline `name` for `features`, if built.
    pub fn get(&self, name: &str, features: Features) -> Option<&wgpu::ComputePipeline> {
        self.cache.get(&(name.to_string(), features))
    }

    /// Number of pipelines built so far.
    pub fn len(&self) -> usize {
        self.cache.len()
    }

    /// `true` before anything is built.
    pub fn is_empty(&self) -> bool {
        self.cache.is_empty()
    }
}
