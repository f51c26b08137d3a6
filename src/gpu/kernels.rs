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

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use super::errors::guarded;
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
    /// At least one sphere, capsule or mesh collider.
    pub spheres: bool,
    /// At least one mesh collider (`[[collider]]`).
    pub mesh_colliders: bool,
    /// Some particle can be constrained in CG (pins or colliders).
    pub filter: bool,
    /// Some spring is damped.
    pub damping: bool,
    /// The linear bending model ([`crate::bending`]).
    pub bending: bool,
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
    /// Self-collision (`[self_collision]`): its dispatches in the plan.
    /// No kernel's code depends on it (the workgroup kernels skip it by
    /// the cloth's feature bit), so it is not a compiled feature: every
    /// variant leaves it as the scene has it, and the pipelines are shared.
    pub self_collision: bool,
}

impl Features {
    /// The scene features as `params.features` holds them
    /// ([`crate::kernel_config::feature`] bits).
    pub fn bits(&self) -> u32 {
        use crate::kernel_config::feature;
        [
            (self.wind, feature::WIND),
            (self.ground, feature::GROUND),
            (self.spheres, feature::SPHERES),
            (self.mesh_colliders, feature::MESH_COLLIDERS),
            (self.filter, feature::FILTER),
            (self.damping, feature::DAMPING),
            (self.bending, feature::BENDING),
            (self.self_collision, feature::SELF_COLLISION),
        ]
        .iter()
        .filter(|(on, _)| *on)
        .fold(0, |bits, (_, bit)| bits | bit)
    }

    /// These features with every scene feature compiled in (wind, ground,
    /// round colliders, filter, damping, bending): the kernels then skip, by
    /// `params.features`, what a cloth lacks. The workgroup kernels are
    /// compiled so — one pipeline per integrator serves every cloth and
    /// every change of its scene, where a variant per feature set would
    /// cost a compile of the whole step each (seconds on a GPU driver, tens
    /// of seconds on a CPU adapter).
    pub fn with_every_scene_feature(self) -> Features {
        Features {
            wind: true,
            ground: true,
            spheres: true,
            mesh_colliders: true,
            filter: true,
            damping: true,
            bending: true,
            ..self
        }
    }
}

/// The one-workgroup kernels' workgroup size on a device with `limits`:
/// [`SUM_GROUP`], or the largest workgroup the device allows (the
/// workgroup path's `cloth_*` kernels, which step a cloth per workgroup,
/// and self-collision's scan). Their sums follow the CPU mirror's order
/// whatever the width: the CG reductions' trees span [`WORKGROUP`] lanes,
/// the further invocations idle through them.
pub fn sum_group(limits: &wgpu::Limits) -> u32 {
    SUM_GROUP
        .min(limits.max_compute_invocations_per_workgroup)
        .min(limits.max_compute_workgroup_size_x)
}

/// Where a pipeline is kept: its kernel, variant and features.
type Key = (Kernel, Variant, Features);

/// The kernel library of one device: cheap to clone (the clones share
/// everything), safe to share between threads.
///
/// Solvers built with [`GpuSolver::with_kernels`](super::GpuSolver::with_kernels)
/// and one library compile each pipeline once between them;
/// [`GpuSolver::new`](super::GpuSolver::new) makes a library of its own.
/// Sharing is explicit: wgpu compares devices by an id that devices of
/// two wgpu instances in one process may share, so a library cannot be
/// found from a device alone.
#[derive(Clone, Debug)]
pub struct GpuKernels {
    inner: Arc<Inner>,
}

#[derive(Debug)]
struct Inner {
    device: wgpu::Device,
    /// Group 0: the buffers of `shaders/common/bindings.wgsl`.
    group0: wgpu::BindGroupLayout,
    /// Group 0 of the workgroup kernels: binding 0 the cloth table (see
    /// `shaders/common/cloth_bindings.wgsl`), the rest as `group0`.
    cloth_group0: wgpu::BindGroupLayout,
    cloth_layout: wgpu::PipelineLayout,
    /// Group 1 of each [`ArgsGroup`], in [`ArgsGroup::ALL`] order.
    args: [wgpu::BindGroupLayout; 3],
    layout: wgpu::PipelineLayout,
    args_layouts: [wgpu::PipelineLayout; 3],
    /// The `skin` kernel's one group: a render mesh's embedding, its vertex
    /// buffer, its parameters, and the cloth's positions, normals and
    /// indices as it is drawn (see `shaders/common/skin.wgsl`).
    skin: wgpu::BindGroupLayout,
    skin_layout: wgpu::PipelineLayout,
    /// wgpu's pipeline cache, on devices with the feature.
    cache: Option<wgpu::PipelineCache>,
    /// A change to one kernel's source (see [`SourcePatch`]).
    patch: Option<SourcePatch>,
    built: Mutex<Built>,
}

/// A change to one kernel's composed source: every `find` replaced by
/// `replace`. For the tests that prove the agreement bounds can fail
/// (`tests/agreement.rs`: a spring term dropped, `dt` one ulp off): a
/// library with a patch compiles that kernel so and every other as it is.
#[doc(hidden)]
#[derive(Clone, Debug)]
pub struct SourcePatch {
    /// The kernel changed.
    pub kernel: Kernel,
    /// The text replaced: it must occur in the kernel's composed source.
    pub find: String,
    /// What replaces it.
    pub replace: String,
}

#[derive(Debug, Default)]
struct Built {
    modules: HashMap<(Kernel, GridBlock), wgpu::ShaderModule>,
    pipelines: HashMap<Key, wgpu::ComputePipeline>,
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

/// A uniform-buffer entry of a bind-group layout.
fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Group 0's storage bindings 1–6 and whether each is read-only (see
/// `shaders/common/layout.wgsl`): model, x, v, work, status,
/// vertex_normals; binding 0 is the uniform block (the cloth table, a
/// storage array, for the workgroup kernels).
pub(crate) const GROUP0_STORAGE: [(u32, bool); 6] = [
    (1, true),
    (2, false),
    (3, false),
    (4, false),
    (5, false),
    (6, false),
];

impl GpuKernels {
    /// An empty library for `device` (with an empty pipeline cache where
    /// the device has the feature): the layouts now, the pipelines as
    /// solvers ask for them.
    pub fn new(device: &wgpu::Device) -> GpuKernels {
        GpuKernels::with_cache(device, None)
    }

    /// A library for `device` whose kernel `patch.kernel` is compiled with
    /// `patch` applied (see [`SourcePatch`]); for tests only.
    #[doc(hidden)]
    pub fn with_patch(device: &wgpu::Device, patch: SourcePatch) -> GpuKernels {
        let mut kernels = GpuKernels::with_cache(device, None);
        if let Some(inner) = Arc::get_mut(&mut kernels.inner) {
            inner.patch = Some(patch);
        }
        kernels
    }

    /// What the pipeline cache holds, to seed a later run's; `None` on a
    /// device without the feature.
    pub(crate) fn cache_data(&self) -> Option<Vec<u8>> {
        self.inner
            .cache
            .as_ref()
            .and_then(wgpu::PipelineCache::get_data)
    }

    /// A library for `device` whose pipeline cache is seeded by
    /// `cache_data` (what [`GpuKernels::cache_data`] returned on an
    /// earlier run; see `src/gpu/pipeline_cache.rs` for how the CLI keeps
    /// it).
    pub(crate) fn with_cache(device: &wgpu::Device, cache_data: Option<&[u8]>) -> GpuKernels {
        let mut entries = vec![uniform_entry(0)];
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
        let mut cloth_entries = vec![storage_entry(0, true)];
        cloth_entries.extend(GROUP0_STORAGE.iter().map(|&(b, ro)| storage_entry(b, ro)));
        let cloth_group0 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wgcloth.cloth_bindings"),
            entries: &cloth_entries,
        });
        let cloth_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wgcloth.cloth_pipeline_layout"),
            bind_group_layouts: &[Some(&cloth_group0)],
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
        let skin = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wgcloth.skin"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, false),
                uniform_entry(2),
                storage_entry(3, true),
                storage_entry(4, true),
                storage_entry(5, true),
            ],
        });
        let skin_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wgcloth.skin"),
            bind_group_layouts: &[Some(&skin)],
            immediate_size: 0,
        });
        GpuKernels {
            inner: Arc::new(Inner {
                device: device.clone(),
                group0,
                cloth_group0,
                cloth_layout,
                args,
                layout,
                args_layouts,
                skin,
                skin_layout,
                cache: super::pipeline_cache::create(device, cache_data),
                patch: None,
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
        self.built().pipelines.len()
    }

    /// Group 0's layout (the buffers every kernel binds).
    pub(super) fn group0(&self) -> &wgpu::BindGroupLayout {
        &self.inner.group0
    }

    /// Group 0's layout of the workgroup kernels
    /// ([`Kernel::steps_cloths`]): the cloth table in binding 0, a
    /// read-only storage array of `Params`, then the buffers of
    /// [`GpuKernels::group0`].
    pub(crate) fn cloth_group0(&self) -> &wgpu::BindGroupLayout {
        &self.inner.cloth_group0
    }

    /// The `skin` kernel's group layout.
    pub(super) fn skin_group(&self) -> &wgpu::BindGroupLayout {
        &self.inner.skin
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
    /// yet, in parallel. A variant that does not belong to its kernel is
    /// an error.
    pub(super) fn pipelines(
        &self,
        wanted: impl IntoIterator<Item = (Kernel, Variant)>,
        features: Features,
    ) -> Result<HashMap<(Kernel, Variant), wgpu::ComputePipeline>> {
        let mut wanted: Vec<(Kernel, Variant)> = wanted.into_iter().collect();
        wanted.sort();
        wanted.dedup();
        if let Some((kernel, variant)) = wanted.iter().find(|(k, v)| !v.is_of(*k)) {
            return Err(Error::Gpu(format!(
                "the kernel {kernel} has no variant {variant:?}"
            )));
        }
        // Self-collision changes which kernels a plan records, not the code
        // of any (no HAS_ constant): one pipeline serves both.
        let features = Features {
            self_collision: false,
            ..features
        };
        let mut built = self.built();
        let missing: Vec<Key> = wanted
            .iter()
            .map(|&(k, v)| (k, v, features))
            .filter(|key| !built.pipelines.contains_key(key))
            .collect();
        for (key, pipeline) in self.compile_all(&mut built, &missing)? {
            built.pipelines.insert(key, pipeline);
        }
        wanted
            .iter()
            .map(|&(k, v)| {
                let pipeline = built.pipelines.get(&(k, v, features)).cloned();
                pipeline
                    .map(|p| ((k, v), p))
                    .ok_or_else(|| Error::Gpu(format!("{k} ({v:?}) was not compiled")))
            })
            .collect()
    }

    /// Compiles `keys`, spread over the host's cores (natively): wgpu's
    /// device is shared between threads, and a driver compiles pipelines of
    /// one device concurrently. Each thread captures its own device errors
    /// (wgpu's error scopes are per thread).
    fn compile_all(
        &self,
        built: &mut Built,
        keys: &[Key],
    ) -> Result<Vec<(Key, wgpu::ComputePipeline)>> {
        // Shader modules first (one per kernel and grid block, parsed by
        // wgpu on this thread), then the pipelines, which is where the
        // driver spends its time.
        for &(kernel, _, features) in keys {
            let block = module_block(kernel, features.block);
            if let Entry::Vacant(e) = built.modules.entry((kernel, block)) {
                e.insert(self.module(kernel, block)?);
            }
        }
        let modules = &built.modules;
        let next = AtomicUsize::new(0);
        // One worker: compiles the next key not yet taken, until none is left.
        let work = || {
            let mut out = Vec::new();
            loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&key) = keys.get(k) else {
                    return Ok(out);
                };
                let module = modules
                    .get(&(key.0, module_block(key.0, key.2.block)))
                    .ok_or_else(|| Error::Gpu(format!("no shader module for {}", key.0)))?;
                out.push((key, self.compile(module, key)?));
            }
        };
        // A browser's wgpu objects are not `Send` (and the page has one
        // thread): one worker compiles them all there.
        #[cfg(target_arch = "wasm32")]
        let results: Vec<Result<Vec<(Key, wgpu::ComputePipeline)>>> = vec![work()];
        #[cfg(not(target_arch = "wasm32"))]
        let results: Vec<Result<Vec<(Key, wgpu::ComputePipeline)>>> = {
            let threads = std::thread::available_parallelism()
                .map_or(1, usize::from)
                .min(keys.len());
            std::thread::scope(|scope| {
                let workers: Vec<_> = (0..threads).map(|_| scope.spawn(work)).collect();
                workers
                    .into_iter()
                    .map(|w| {
                        w.join().unwrap_or_else(|_| {
                            Err(Error::Gpu("a thread compiling the kernels panicked".into()))
                        })
                    })
                    .collect()
            })
        };
        let mut out = Vec::with_capacity(keys.len());
        for r in results {
            out.extend(r?);
        }
        Ok(out)
    }

    /// The shader module of `kernel` with its grid gather for `block`.
    fn module(&self, kernel: Kernel, block: GridBlock) -> Result<wgpu::ShaderModule> {
        let mut source = shaders::kernel_source(kernel, block).map_err(Error::Gpu)?;
        if let Some(patch) = self.inner.patch.as_ref().filter(|p| p.kernel == kernel) {
            if !source.contains(&patch.find) {
                return Err(Error::Gpu(format!(
                    "the patch of {kernel} finds no {:?} in its source",
                    patch.find
                )));
            }
            source = source.replace(&patch.find, &patch.replace);
        }
        let device = &self.inner.device;
        guarded(
            device,
            &format!("compiling shaders/{kernel}.wgsl"),
            None,
            || {
                Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(&format!("wgcloth.{kernel}")),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                }))
            },
        )
    }

    /// The pipeline of `key` from `module`.
    fn compile(&self, module: &wgpu::ShaderModule, key: Key) -> Result<wgpu::ComputePipeline> {
        let (kernel, variant, features) = key;
        let device = &self.inner.device;
        let flag = |on: bool| f64::from(u8::from(on));
        let mut constants: Vec<(&str, f64)> = vec![
            ("WORKGROUP", f64::from(WORKGROUP)),
            ("HAS_WIND", flag(features.wind)),
            ("HAS_GROUND", flag(features.ground)),
            ("HAS_SPHERES", flag(features.spheres)),
            ("HAS_MESH_COLLIDERS", flag(features.mesh_colliders)),
            ("HAS_FILTER", flag(features.filter)),
            ("HAS_DAMPING", flag(features.damping)),
            ("HAS_BENDING", flag(features.bending)),
            ("GRID", flag(features.grid)),
            ("CONSTANT_BLOCKS", flag(features.constant_blocks)),
            ("COARSE", flag(features.coarse)),
            ("SUM_GROUP", f64::from(sum_group(&device.limits()))),
        ];
        if kernel.has_own_bindings() {
            // Only the generated configuration's overrides are declared.
            constants.retain(|(name, _)| matches!(*name, "WORKGROUP" | "SUM_GROUP"));
        }
        constants.extend(variant.constants(kernel));
        let layout = match kernel.args_group() {
            Some(g) => &self.inner.args_layouts[g.index()],
            None if kernel.steps_cloths() => &self.inner.cloth_layout,
            None if kernel.has_own_bindings() => &self.inner.skin_layout,
            None => &self.inner.layout,
        };
        let what = format!("compiling the kernel {kernel} ({variant:?})");
        guarded(device, &what, None, || {
            Ok(
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(&format!("wgcloth.{kernel}.{variant:?}")),
                    layout: Some(layout),
                    module,
                    entry_point: Some(kernel.name()),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        zero_initialize_workgroup_memory: false,
                    },
                    cache: self.inner.cache.as_ref(),
                }),
            )
        })
    }
}

/// The grid block `kernel`'s module is composed for, in a solver of
/// `block`: its own unless the kernel gathers one particle per invocation
/// whatever the shape ([`Kernel::takes_grid_block`]).
fn module_block(kernel: Kernel, block: GridBlock) -> GridBlock {
    if kernel.takes_grid_block() {
        block
    } else {
        GridBlock::ONE
    }
}

/// The kernel whose group 1 `group` is.
fn args_kernel(group: ArgsGroup) -> Kernel {
    match group {
        ArgsGroup::Start => Kernel::CgInit,
        ArgsGroup::Apply => Kernel::CgApply,
        ArgsGroup::Update => Kernel::CgUpdate,
    }
}
