//! The device-wide kernel library: the bind-group layouts every solver's
//! buffers follow and the compute pipelines, compiled once per device,
//! kernel variant and feature set and shared by every solver built with
//! the same [`GpuKernels`].
//!
//! A pipeline is a kernel (`shaders/NAME.wgsl`, [`Kernel`]) plus
//! `override` constants: the workgroup sizes, the features (`HAS_WIND`,
//! `HAS_GROUND`, `HAS_SPHERES`, … — code of an absent feature is compiled
//! out), and the variant's own ([`Variant`]). A solver asks for the
//! pipelines its step plan records and nothing else; switching a scene's
//! features back and forth costs one compile per new variant, then
//! nothing.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use super::grid::GridBlock;
use super::kernel::{ArgsGroup, Kernel, Variant};
use super::shaders;
use crate::error::{Error, Result};
use crate::kernel_config::{SUM_GROUP, WORKGROUP};

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
    /// The CG matrix is the semi-implicit constant one (`CONSTANT_BLOCKS`
    /// in `shaders/common/bindings.wgsl`).
    pub constant_blocks: bool,
}

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

/// Where a pipeline is kept: its kernel, variant and features.
type Key = (Kernel, Variant, Features);

/// The kernel library of one device: cheap to clone (the clones share
/// everything), safe to share between threads. Build solvers with
/// [`GpuSolver::with_kernels`](super::GpuSolver::with_kernels) to share it;
/// [`GpuSolver::new`](super::GpuSolver::new) makes one of its own.
#[derive(Clone, Debug)]
pub struct GpuKernels {
    inner: Arc<Inner>,
}

#[derive(Debug)]
struct Inner {
    device: wgpu::Device,
    /// Group 0: the buffers of `shaders/common/bindings.wgsl`.
    group0: wgpu::BindGroupLayout,
    /// Group 1 of each [`ArgsGroup`], in [`ArgsGroup::ALL`] order.
    args: [wgpu::BindGroupLayout; 3],
    layout: wgpu::PipelineLayout,
    args_layouts: [wgpu::PipelineLayout; 3],
    built: Mutex<Built>,
}

#[derive(Debug, Default)]
struct Built {
    modules: HashMap<(Kernel, GridBlock), wgpu::ShaderModule>,
    pipelines: HashMap<Key, wgpu::ComputePipeline>,
    /// Pipelines compiled so far.
    compiled: usize,
}

/// A storage-buffer entry of a bind-group layout.
fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Group 0's storage bindings 1–10 and whether each is read-only (see
/// `shaders/common/bindings.wgsl`); binding 0 is the uniform block.
const GROUP0_STORAGE: [(u32, bool); 10] = [
    (1, true),
    (2, true),
    (3, false),
    (4, false),
    (5, false),
    (6, false),
    (7, false),
    (8, false),
    (9, false),
    (10, true),
];

impl GpuKernels {
    /// An empty library for `device`: the layouts now, the pipelines as
    /// solvers ask for them.
    pub fn new(device: &wgpu::Device) -> GpuKernels {
        let mut entries = vec![wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }];
        entries.extend(GROUP0_STORAGE.iter().map(|&(b, ro)| storage_entry(b, ro)));
        let group0 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wgcloth.bindings"),
            entries: &entries,
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wgcloth.pipeline_layout"),
            bind_group_layouts: &[Some(&group0)],
            immediate_size: 0,
        });
        let args = ArgsGroup::ALL.map(|g| {
            let entries: Vec<_> = g
                .bindings()
                .iter()
                .map(|&b| storage_entry(b, false))
                .collect();
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(&format!("wgcloth.args.{}", args_kernel(g))),
                entries: &entries,
            })
        });
        let args_layouts = ArgsGroup::ALL.map(|g| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(&format!("wgcloth.args.{}", args_kernel(g))),
                bind_group_layouts: &[Some(&group0), Some(&args[g.index()])],
                immediate_size: 0,
            })
        });
        GpuKernels {
            inner: Arc::new(Inner {
                device: device.clone(),
                group0,
                args,
                layout,
                args_layouts,
                built: Mutex::new(Built::default()),
            }),
        }
    }

    /// The device the library compiles for.
    pub fn device(&self) -> &wgpu::Device {
        &self.inner.device
    }

    /// Pipelines compiled so far (each kernel variant and feature set
    /// once).
    pub fn compiled(&self) -> usize {
        self.built().compiled
    }

    /// Group 0's layout (the buffers every kernel binds).
    pub(super) fn group0(&self) -> &wgpu::BindGroupLayout {
        &self.inner.group0
    }

    /// Group 1's layout of a kernel that writes dispatch arguments.
    pub(super) fn args_layout(&self, group: ArgsGroup) -> &wgpu::BindGroupLayout {
        &self.inner.args[group.index()]
    }

    fn built(&self) -> std::sync::MutexGuard<'_, Built> {
        // A panic while holding the lock leaves the maps consistent (an
        // insert is the last thing done), so a poisoned lock is usable.
        self.inner
            .built
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
    }

    /// The pipelines of `wanted` for `features`, compiling those not built
    /// yet. A variant that does not belong to its kernel is an error.
    pub(super) fn pipelines(
        &self,
        wanted: impl IntoIterator<Item = (Kernel, Variant)>,
        features: Features,
    ) -> Result<HashMap<(Kernel, Variant), wgpu::ComputePipeline>> {
        let mut out = HashMap::new();
        let mut built = self.built();
        for (kernel, variant) in wanted {
            if out.contains_key(&(kernel, variant)) {
                continue;
            }
            if !variant.is_of(kernel) {
                return Err(Error::Gpu(format!(
                    "the kernel {kernel} has no variant {variant:?}"
                )));
            }
            let key = (kernel, variant, features);
            let pipeline = match built.pipelines.get(&key) {
                Some(p) => p.clone(),
                None => {
                    let p = self.compile(&mut built, key)?;
                    built.pipelines.insert(key, p.clone());
                    built.compiled += 1;
                    p
                }
            };
            out.insert((kernel, variant), pipeline);
        }
        Ok(out)
    }

    fn compile(&self, built: &mut Built, key: Key) -> Result<wgpu::ComputePipeline> {
        let (kernel, variant, features) = key;
        let device = &self.inner.device;
        let module = match built.modules.get(&(kernel, features.block)) {
            Some(m) => m.clone(),
            None => {
                let source = shaders::kernel_source(kernel, features.block).map_err(Error::Gpu)?;
                let m = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(&format!("wgcloth.{kernel}")),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
                built.modules.insert((kernel, features.block), m.clone());
                m
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
            ("CONSTANT_BLOCKS", flag(features.constant_blocks)),
            ("COARSE", flag(features.coarse)),
            ("SUM_GROUP", f64::from(sum_group(&device.limits()))),
        ];
        constants.extend(variant.constants(kernel));
        let layout = match kernel.args_group() {
            Some(g) => &self.inner.args_layouts[g.index()],
            None => &self.inner.layout,
        };
        Ok(
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&format!("wgcloth.{kernel}.{variant:?}")),
                layout: Some(layout),
                module: &module,
                entry_point: Some(kernel.name()),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            }),
        )
    }
}

/// The kernel whose group 1 `group` is.
fn args_kernel(group: ArgsGroup) -> Kernel {
    match group {
        ArgsGroup::Start => Kernel::CgStart,
        ArgsGroup::Alpha => Kernel::CgAlpha,
        ArgsGroup::Beta => Kernel::CgBeta,
    }
}
