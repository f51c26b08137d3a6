//! The GPU solver: buffers, pipelines and the recording of steps.

use super::buffers::ClothBuffers;
use super::cg_budget::CgBudget;
use super::errors::{block_on, guarded, guarded_async};
use super::grid::{GridBlock, GridLayout};
use super::kernel::{Dispatch, Kernel, Launch};
use super::kernels::{Features, GpuKernels};
use super::layout::{
    self, GpuCapsule, GpuMeshCollider, GpuParams, GpuSphere, MAX_CAPSULES, MAX_MESH_COLLIDERS,
    MAX_SPHERES,
};
use super::path::{self, PathChoice, PathInputs, StepPath};
use super::path_cost::{self, AdapterCost};
use super::plan::{self, Plan, PlanInputs};
use super::readback;
use super::semi_filter::SemiFilter;
use super::DrawRange;
use crate::aggregation::Aggregation;
use crate::budget::{self, Counts};
use crate::diagnostics::Motion;
use crate::error::{Error, Result};
use crate::kernel_config::WORKGROUP;
use crate::model::Model;
use crate::params::{Capsule, FilterMethod, Ground, Integrator, Params, Sphere, Wind};
use crate::sdf::MeshCollider;
use crate::stats::StepStats;
use glam::{DVec3, Vec3};

/// A dispatch with the pipeline it runs.
pub(super) type Entry = (Dispatch, wgpu::ComputePipeline);

/// A step number the device counts in 32 bits (it wraps after 4.3·10⁹
/// steps), widened with the host's count of recorded steps, which is never
/// smaller and never 2³² steps ahead: the largest value not above
/// `recorded` that is `low` modulo 2³².
pub(super) fn widen_step(low: u32, recorded: u64) -> u64 {
    recorded - u64::from((recorded as u32).wrapping_sub(low))
}

/// What a cloth's status words (`status::COUNT` of them) say, after
/// `steps_recorded` steps of `dt` \[s\]: its statistics, or the error
/// naming the first step whose state was not finite.
pub(super) fn decode_status(
    words: &[u32],
    steps_recorded: u64,
    dt: f64,
    cg_budget_hits: Option<u64>,
) -> Result<StepStats> {
    let bad = words[layout::status::BAD_STEP];
    if bad != u32::MAX {
        let step = widen_step(bad, steps_recorded);
        return Err(Error::NonFinite {
            step,
            time: step as f64 * dt,
            particle: words[layout::status::BAD_PARTICLE] as usize,
        });
    }
    Ok(StepStats {
        steps: widen_step(words[layout::status::STEP], steps_recorded),
        cg_iterations: words[layout::status::CG_ITERATIONS],
        cg_max_iterations: words[layout::status::CG_MAX_ITERATIONS],
        cg_residual: None,
        cg_budget_hits,
        fixup_passes: words[layout::status::FIXUP_PASSES],
    })
}

/// Storage buffers a kernel binds at most: group 0's six (see
/// `shaders/common/layout.wgsl`) and cg_init's two dispatch-argument
/// buffers in group 1 — the eight per shader stage that every WebGPU
/// device grants (`wgpu::Limits::default()`). A workgroup kernel binds
/// group 0's six and its cloth table.
pub(super) const STORAGE_BUFFERS: u32 = 8;
const _: () =
    assert!(STORAGE_BUFFERS <= wgpu::Limits::defaults().max_storage_buffers_per_shader_stage);

/// Positions and velocities read back from the device.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuState {
    /// Positions \[m\].
    pub x: Vec<Vec3>,
    /// Velocities [m/s].
    pub v: Vec<Vec3>,
}

impl GpuState {
    /// The state from the bytes of `x` and `v` as read back (`vec4<f32>`
    /// per particle, w dropped); copied out, so the bytes need not be
    /// aligned for `f32`.
    pub(super) fn from_bytes(x: &[u8], v: &[u8]) -> GpuState {
        let unpack = |b: &[u8]| -> Vec<Vec3> {
            bytemuck::pod_collect_to_vec::<u8, [f32; 4]>(b)
                .iter()
                .map(|q| Vec3::new(q[0], q[1], q[2]))
                .collect()
        };
        GpuState {
            x: unpack(x),
            v: unpack(v),
        }
    }
}

/// A cloth simulated on a wgpu device the host owns.
///
/// Made from the same [`Model`] and [`Params`] as the CPU solver. It keeps
/// handles to the host's device and queue (wgpu handles are reference
/// counted) but never creates an instance, adapter or device.
///
/// Stepping never reads back: [`GpuSolver::encode_steps`] records into the
/// caller's encoder; [`GpuSolver::step`] records and submits. A state that
/// stops being finite is caught on the device — the particle keeps its last
/// finite state, so a renderer never receives NaN vertices, and the first
/// such step is recorded — and reported by [`GpuSolver::check`], which
/// [`GpuSolver::step`] calls after each submit and [`GpuSolver::read_state`]
/// before it returns.
#[derive(Debug)]
pub struct GpuSolver {
    pub(super) device: wgpu::Device,
    pub(super) queue: wgpu::Queue,
    pub(super) integrator: Integrator,
    /// Spring slots on the device: the springs, or six per particle in
    /// grid layout.
    pub(super) spring_slots: u32,
    /// The springs are in grid layout (see [`super::grid`]).
    pub(super) grid: bool,
    /// Particles per invocation of the grid gather kernels.
    pub(super) block: GridBlock,
    /// Fix-up passes per step.
    pub(super) fixup_iterations: u32,
    /// CG iterations recorded per step.
    pub(super) cg: CgBudget,
    /// The uniform block as uploaded (particle and triangle counts too).
    pub(super) params: GpuParams,
    /// The cloth's buffers and bind groups.
    pub(super) buffers: ClothBuffers,
    pub(super) kernels: GpuKernels,
    /// The step plan with its pipelines.
    pub(super) prepared: Prepared,
    pub(super) features: Features,
    pub(super) steps_recorded: u64,
    pub(super) dt: f64,
    /// The model with its current pins (a dense filter is rebuilt from it).
    pub(super) model: Model,
    /// Dispatches recorded by the last `encode_steps`, and its steps.
    pub(super) recorded: std::cell::Cell<(u32, u32)>,
    /// Scene-specialised kernels (the default) or the general ones.
    pub(super) specialised: bool,
    /// The parameters with the current colliders, wind and gravity.
    pub(super) host_params: Params,
    /// How a step is recorded, and why.
    pub(super) path: PathChoice,
    /// The moving bodies, for [`GpuSolver::check_divergence`].
    pub(super) motion: Motion,
    /// Copies of the buffers a step changes, made before a
    /// [`GpuSolver::step`] that the CG budget may cut short (see
    /// [`Rewind`]); made when first needed.
    pub(super) rewind: Option<Rewind>,
}

/// Copies of the buffers a step writes (positions, velocities, the
/// scratch with its warm start and pin goals, the status words): taken
/// before the steps of a [`GpuSolver::step`] whose CG budget is below its
/// maximum, and put back if one of those steps used the whole budget, so
/// that the steps run again with the maximum. A step the budget cut short
/// stopped above the CG tolerance; run again, it is the step the `f32`
/// mirror takes, so `step` never depends on the budget.
#[derive(Debug)]
pub(super) struct Rewind {
    /// Copies of `ClothBuffers::stepped`, in its order.
    copies: Vec<wgpu::Buffer>,
}

impl Rewind {
    /// Copies the size of `buffers`' state buffers.
    fn new(device: &wgpu::Device, buffers: &ClothBuffers) -> Rewind {
        let copies = buffers
            .stepped()
            .iter()
            .map(|b| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("wgcloth.rewind"),
                    size: b.size(),
                    usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
            .collect();
        Rewind { copies }
    }

    /// Records copies of `buffers`' state into the rewind's.
    fn save(&self, encoder: &mut wgpu::CommandEncoder, buffers: &ClothBuffers) {
        for (b, copy) in buffers.stepped().iter().zip(&self.copies) {
            encoder.copy_buffer_to_buffer(b, 0, copy, 0, b.size());
        }
    }

    /// Records copies of the rewind's buffers back into `buffers`.
    fn restore(&self, encoder: &mut wgpu::CommandEncoder, buffers: &ClothBuffers) {
        for (b, copy) in buffers.stepped().iter().zip(&self.copies) {
            encoder.copy_buffer_to_buffer(copy, 0, b, 0, b.size());
        }
    }
}

/// What a submit of steps records before them (see [`Rewind`]).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Before {
    Nothing,
    /// Copy the state into the rewind (made if there is none).
    Save,
    /// Copy the rewind back into the state.
    Restore,
}

/// What the step plan depends on (`params`: as uploaded).
pub(super) fn plan_inputs(
    integrator: Integrator,
    features: Features,
    params: &GpuParams,
    spring_slots: u32,
    fixup_iterations: u32,
    path: StepPath,
) -> PlanInputs {
    let particles = params.particle_count;
    PlanInputs {
        integrator,
        features,
        particles,
        spring_slots,
        gather: if features.grid {
            params.grid[3]
        } else {
            particles
        },
        aggregates: [params.coarse[2], params.coarse[3]],
        filter_count: params.filter_count,
        torque: params.torque_compensation & layout::TORQUE_GLOBAL != 0,
        fixup_iterations,
        self_collision_passes: if features.self_collision {
            params.self_grid[0]
        } else {
            0
        },
        path,
    }
}

/// The step plan with the pipelines it records, taken from the kernel
/// library (which compiles those it lacks): a plan recorded afterwards
/// cannot meet a pipeline that was not built.
#[derive(Debug)]
pub(super) struct Prepared {
    /// What the plan was built from.
    inputs: PlanInputs,
    /// The step plan.
    pub(super) steps: Plan<Entry>,
    /// The vertex-normal pass.
    pub(super) normals: wgpu::ComputePipeline,
}

impl Prepared {
    pub(super) fn new(kernels: &GpuKernels, inputs: &PlanInputs) -> Result<Prepared> {
        let plan = Plan::new(inputs);
        let normals = Dispatch::direct(Kernel::Normals, inputs.particles);
        let wanted = plan.entries().chain([&normals]).map(Dispatch::pipeline);
        let device = kernels.device().clone();
        let pipelines = guarded(&device, "compiling the kernels", None, || {
            kernels.pipelines(wanted, inputs.features)
        })?;
        let take = |d: &Dispatch| {
            pipelines
                .get(&d.pipeline())
                .cloned()
                .map(|p| (*d, p))
                .ok_or_else(|| Error::Gpu(format!("no pipeline was built for {d:?}")))
        };
        Ok(Prepared {
            inputs: *inputs,
            steps: plan.try_map(take)?,
            normals: take(&normals)?.1,
        })
    }
}

/// What the scene uses, for the kernel variants.
/// `grid`: the block shape of the grid kernels, `None` without grid layout.
pub(super) fn scene_features(model: &Model, params: &Params, grid: Option<GridBlock>) -> Features {
    let meshes = !params.mesh_colliders.is_empty();
    let round = !params.spheres.is_empty() || !params.capsules.is_empty() || meshes;
    let colliders = params.ground.is_some() || round;
    Features {
        wind: params.wind.is_some(),
        ground: params.ground.is_some(),
        // The kernels' HAS_SPHERES covers every body collider (it gates
        // their contact code); HAS_MESH_COLLIDERS the grids' sampling.
        spheres: round,
        mesh_colliders: meshes,
        filter: colliders || model.pinned_count() > 0,
        damping: params
            .springs
            .iter()
            .any(|k| k.stiffness > 0.0 && k.damping > 0.0),
        bending: model.bending.is_some(),
        grid: grid.is_some(),
        block: grid.unwrap_or(GridBlock::ONE),
        coarse: Aggregation::for_scene(model, params).is_some(),
        constant_blocks: params.integrator == Integrator::SemiImplicit,
        self_collision: params.self_collision.is_some(),
    }
}

/// The features a solver's pipelines are compiled with for a scene with
/// `scene` features on `path`: the scene's own on the multi-dispatch path;
/// every scene feature on the workgroup path (see
/// [`Features::with_every_scene_feature`]), as a batch's table does.
pub(super) fn compiled_features(scene: Features, path: StepPath) -> Features {
    match path {
        StepPath::Workgroup => scene.with_every_scene_feature(),
        StepPath::MultiDispatch => scene,
    }
}

/// Uniform values when there is no wind (the kernels compile it out).
pub(super) const NO_WIND: Wind = Wind {
    velocity: DVec3::ZERO,
    drag: 0.0,
    lift: 0.0,
};

/// Uniform values when there is no ground: the kernels compile it out,
/// and the general variant (see [`GpuTuningMut::set_specialised`](super::GpuTuningMut::set_specialised)) never
/// reaches a plane this far down.
pub(super) const NO_GROUND: Ground = Ground {
    height: -1e30,
    friction: 0.0,
};

/// Spheres as the uniform block holds them (the caller checks the count).
pub(super) fn gpu_spheres(spheres: &[Sphere]) -> [GpuSphere; MAX_SPHERES] {
    let mut out = [GpuSphere::default(); MAX_SPHERES];
    for (g, s) in out.iter_mut().zip(spheres) {
        *g = GpuSphere {
            center: s.center.as_vec3().to_array(),
            radius: s.radius as f32,
            velocity: s.velocity.as_vec3().to_array(),
            friction: s.friction as f32,
        };
    }
    out
}

/// Capsules as the uniform block holds them (the caller checks the count).
pub(super) fn gpu_capsules(capsules: &[Capsule]) -> [GpuCapsule; MAX_CAPSULES] {
    let mut out = [GpuCapsule::default(); MAX_CAPSULES];
    for (g, c) in out.iter_mut().zip(capsules) {
        *g = GpuCapsule {
            a: c.a.as_vec3().to_array(),
            radius: c.radius as f32,
            b: c.b.as_vec3().to_array(),
            friction: c.friction as f32,
            velocity: c.velocity.as_vec3().to_array(),
            _pad: 0.0,
        };
    }
    out
}

/// Mesh colliders' poses as the uniform block holds them (the caller
/// checks the count), each with its grid's header at `grids[k]` (a `vec4`
/// index in `model`).
pub(super) fn gpu_mesh_colliders(
    colliders: &[MeshCollider],
    grids: &[u32],
) -> [GpuMeshCollider; MAX_MESH_COLLIDERS] {
    let mut out = [GpuMeshCollider::default(); MAX_MESH_COLLIDERS];
    for ((g, m), &grid) in out.iter_mut().zip(colliders).zip(grids) {
        *g = GpuMeshCollider {
            rotation: m.rotation.inverse().as_quat().to_array(),
            position: m.position.as_vec3().to_array(),
            friction: m.friction as f32,
            velocity: m.velocity.as_vec3().to_array(),
            thickness: m.thickness as f32,
            angular_velocity: m.angular_velocity.as_vec3().to_array(),
            grid,
        };
    }
    out
}

/// Refuses more spheres, capsules or mesh colliders than the uniform block
/// holds, before anything runs.
pub(super) fn check_collider_counts(spheres: usize, capsules: usize, meshes: usize) -> Result<()> {
    for (key, count, max) in [
        ("sphere", spheres, MAX_SPHERES),
        ("capsule", capsules, MAX_CAPSULES),
        ("collider", meshes, MAX_MESH_COLLIDERS),
    ] {
        if count > max {
            return Err(Error::InvalidParameter {
                key: key.into(),
                allowed: format!("at most {max} {key}s on the GPU backend"),
                got: count.to_string(),
            });
        }
    }
    Ok(())
}

/// Whether the device can bind the model buffer of `model` with the dense
/// semi-implicit filter (sized for every particle free): the automatic
/// filter choice takes CG where it cannot (WebGPU's default binding limit
/// of 128 MiB holds the filter of about 5 800 particles), a dense filter
/// asked for is refused by the limit check instead.
fn dense_fits(model: &Model, counts: Counts, params: &Params, limits: &wgpu::Limits) -> bool {
    // The most spring slots either layout may take: six per particle on a
    // grid.
    let slots = (model.springs.len() as u64).max(6 * counts.particles);
    let need = budget::gpu_bytes(counts, slots, params, true, 0);
    need.largest
        <= limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
}

/// Refuses `needed` when the device's limit `name` is only `available`;
/// `what` is what needs it.
pub(super) fn limit(name: &'static str, what: &str, available: u64, needed: u64) -> Result<()> {
    if needed > available {
        Err(Error::DeviceLimit {
            what: what.to_string(),
            limit: name,
            available,
            needed,
        })
    } else {
        Ok(())
    }
}

impl GpuSolver {
    /// Builds the solver on the host's `device` and `queue`. Refuses, before
    /// allocating anything, invalid parameters, a cloth that exceeds the
    /// device's limits (the error names the limit and the size asked for)
    /// and one that needs more memory than the host has
    /// ([`Error::OutOfMemory`]; see [`crate::budget`]). A device error while
    /// building (out of device memory, validation) is an error too.
    ///
    /// The solver compiles its pipelines into a kernel library of its own;
    /// solvers built with [`GpuSolver::with_kernels`] and one library
    /// compile each kernel variant once between them.
    ///
    /// Native only: in a browser, which cannot wait for the device's
    /// verdict, it is an error saying to await [`GpuSolver::new_async`].
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
    ) -> Result<GpuSolver> {
        block_on(
            "GpuSolver::new_async",
            GpuSolver::new_async(device, queue, model, params),
        )
    }

    /// [`GpuSolver::new`] as a future, for a browser's event loop (it
    /// resolves when the device has reported its errors, if any).
    pub async fn new_async(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
    ) -> Result<GpuSolver> {
        GpuSolver::with_kernels_async(&GpuKernels::new(device), queue, model, params).await
    }

    /// [`GpuSolver::new`] on the device of `kernels`, taking its pipelines
    /// from that library.
    ///
    /// The solver steps the cloth on the path a cost model of the adapter
    /// and the step estimates faster, the multi-dispatch path where the
    /// workgroup path cannot step it (see [`StepPath`] and
    /// [`GpuTuning::step_path_reason`](super::GpuTuning::step_path_reason)).
    pub fn with_kernels(
        kernels: &GpuKernels,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
    ) -> Result<GpuSolver> {
        block_on(
            "GpuSolver::with_kernels_async",
            GpuSolver::create(kernels, queue, model, params, None),
        )
    }

    /// [`GpuSolver::with_kernels`] as a future.
    pub async fn with_kernels_async(
        kernels: &GpuKernels,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
    ) -> Result<GpuSolver> {
        GpuSolver::create(kernels, queue, model, params, None).await
    }

    /// [`GpuSolver::with_kernels`] on the step path `path` rather than the
    /// one it would choose (for tests and benchmarks: both paths give the
    /// same results). The workgroup path for a cloth it cannot step —
    /// beyond [`WORKGROUP_STEP_MAX_PARTICLES`](crate::kernel_config::WORKGROUP_STEP_MAX_PARTICLES)
    /// particles, an integrator or filter without a workgroup kernel, a
    /// device with too small a workgroup — is an error that says which.
    pub fn with_step_path(
        kernels: &GpuKernels,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
        path: StepPath,
    ) -> Result<GpuSolver> {
        block_on(
            "GpuSolver::with_kernels_async",
            GpuSolver::create(kernels, queue, model, params, Some(path)),
        )
    }

    async fn create(
        kernels: &GpuKernels,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
        forced: Option<StepPath>,
    ) -> Result<GpuSolver> {
        let device = kernels.device();
        params.validate()?;
        crate::material::check_explicit_bending(model, params)?;
        crate::self_collision::thickness(model, params)?;
        crate::self_collision::check_gpu(params)?;
        let counts = Counts::of_model(model);
        let limits = device.limits();
        let dense = params.integrator == Integrator::SemiImplicit
            && params.semi_implicit.filter.is_dense(counts.free as usize)
            && (params.semi_implicit.filter != FilterMethod::Auto
                || dense_fits(model, counts, params, &limits));
        let grid = GridLayout::of(model, params);
        let info = device.adapter_info();
        let block = GridBlock::ONE;
        let path = path::choose(
            &PathInputs {
                integrator: params.integrator,
                particles: counts.particles,
                dense,
                limits: &limits,
            },
            forced,
            &path::work(model, params, dense, grid.as_ref(), block),
            &AdapterCost::of(info.device_type, path_cost::cpu_threads()),
        )?;
        // The workgroup kernels read the adjacency lists: a grid cloth on
        // that path is uploaded in general layout.
        let grid = match path.path {
            StepPath::Workgroup => None,
            StepPath::MultiDispatch => grid,
        };
        let n = counts.particles;
        let s = grid.as_ref().map_or(model.springs.len(), GridLayout::slots) as u64;
        let solver = "the solver";
        limit("max_bind_groups", solver, limits.max_bind_groups.into(), 2)?;
        limit(
            "max_storage_buffers_per_shader_stage",
            solver,
            limits.max_storage_buffers_per_shader_stage.into(),
            STORAGE_BUFFERS.into(),
        )?;
        limit(
            "max_compute_workgroup_size_x",
            solver,
            limits.max_compute_workgroup_size_x.into(),
            WORKGROUP.into(),
        )?;
        let bandwidth = if dense {
            budget::filter_bandwidth(model)
        } else {
            0
        };
        let need = budget::gpu_bytes(counts, s, params, dense, bandwidth);
        let buffer = "the cloth's largest buffer (bytes)";
        limit(
            "max_storage_buffer_binding_size",
            buffer,
            limits.max_storage_buffer_binding_size,
            need.largest,
        )?;
        limit(
            "max_buffer_size",
            buffer,
            limits.max_buffer_size,
            need.largest,
        )?;
        let groups = n.max(s).div_ceil(u64::from(WORKGROUP));
        limit(
            "max_compute_workgroups_per_dimension",
            "the cloth's particles or springs (workgroups)",
            limits.max_compute_workgroups_per_dimension.into(),
            groups,
        )?;
        check_collider_counts(
            params.spheres.len(),
            params.capsules.len(),
            params.mesh_colliders.len(),
        )?;
        let what = if dense {
            format!(
                "the GPU solver for {n} particles with the dense semi-implicit filter \
                 ({n} × {n} entries on the device; `filter = \"banded\"` solves it by CG)"
            )
        } else {
            format!("the GPU solver for {n} particles")
        };
        budget::check_gpu_host(device, need.host, need.device, || what.clone())?;

        let filter = if params.integrator == Integrator::SemiImplicit {
            Some(SemiFilter::new(model, params, dense)?)
        } else {
            None
        };
        guarded_async(device, &what, Some(need.device), || {
            Self::build(queue, model, params, filter, grid, kernels.clone(), path)
        })
        .await
    }

    /// Records `d` with `pipeline` (the CG iterations' kernels: launched
    /// from the slot of CG iteration `iteration`).
    pub(super) fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        d: &Dispatch,
        pipeline: &wgpu::ComputePipeline,
        iteration: u32,
    ) {
        let (n, s) = self.recorded.get();
        self.recorded.set((n + 1, s));
        pass.set_pipeline(pipeline);
        if let Some(g) = d.kernel.args_group() {
            pass.set_bind_group(1, &self.buffers.args_groups[g.index()], &[]);
        }
        let launch = plan::in_iteration(*d, iteration).launch;
        match launch {
            Launch::Direct => {
                pass.dispatch_workgroups(d.items.div_ceil(d.kernel.workgroup_size()), 1, 1)
            }
            Launch::Cloths(n) => {
                if let Some(group) = &self.buffers.cloth_group {
                    pass.set_bind_group(0, group, &[]);
                }
                pass.dispatch_workgroups(n, 1, 1)
            }
            Launch::ApplySlot(_) | Launch::UpdateSlot(_) => {
                if let Some((buffer, offset)) = launch.args() {
                    pass.dispatch_workgroups_indirect(self.buffers.args(buffer), offset)
                }
            }
        }
    }

    /// Records `n` steps into `encoder` without submitting. All steps go
    /// into one compute pass.
    pub fn encode_steps(&mut self, encoder: &mut wgpu::CommandEncoder, n: u32) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wgcloth.steps"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.buffers.bind_group, &[]);
        self.recorded.set((0, n));
        self.prepared
            .steps
            .for_each(n, self.cg.current(), |(d, p), k| {
                self.dispatch(&mut pass, d, p, k)
            });
        self.steps_recorded += u64::from(n);
    }

    /// What the step plan depends on.
    pub(super) fn plan_inputs(&self) -> PlanInputs {
        plan_inputs(
            self.integrator,
            self.features,
            &self.params,
            self.spring_slots,
            self.fixup_iterations,
            self.path.path,
        )
    }

    /// Rebuilds the step plan of the current scene (see [`Prepared`]),
    /// unless nothing it depends on changed: a game moving its colliders
    /// every frame keeps the plan it has.
    pub(super) fn prepare(&mut self) -> Result<()> {
        let inputs = self.plan_inputs();
        if inputs != self.prepared.inputs {
            self.prepared = Prepared::new(&self.kernels, &inputs)?;
        }
        Ok(())
    }

    /// The dispatches of one step of a long run, in order: with
    /// single-pass explicit steps, one that reads x and v (an odd number of
    /// steps first records `explicit_seed`; see [`super::plan`]).
    pub(super) fn step_plan(&self) -> Vec<Dispatch> {
        self.prepared.steps.dispatches(None, self.cg.current())
    }

    /// The step plan grouped by kernel, in order of first appearance:
    /// `(kernel, dispatches per step, invocations per dispatch)` — what
    /// `wgcloth run --verbose` prints.
    pub(super) fn describe_step(&self) -> Vec<(&'static str, u32, u32)> {
        super::profile::per_kernel(&self.step_plan())
            .into_iter()
            .map(|(k, count, items)| (k.name(), count, items))
            .collect()
    }

    /// Records the vertex-normal pass (for rendering; stepping never needs
    /// it).
    pub fn encode_normals(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wgcloth.normals"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.buffers.bind_group, &[]);
        let normals = Dispatch::direct(Kernel::Normals, self.params.particle_count);
        self.dispatch(&mut pass, &normals, &self.prepared.normals, 0);
    }

    /// Records and submits `n` steps in one encoder, then checks the
    /// device's status word (one small read-back per call, none per step).
    /// A device error (a lost device, out of memory) is an
    /// [`Error::Gpu`], never a panic. Native only, as
    /// [`GpuSolver::check`] is.
    pub fn step(&mut self, n: u32) -> Result<StepStats> {
        block_on("GpuSolver::step_async", self.step_async(n))
    }

    /// [`GpuSolver::step`] as a future, for a browser's event loop.
    pub async fn step_async(&mut self, n: u32) -> Result<StepStats> {
        // Below its maximum, the CG budget may cut a step short: keep what
        // the steps change, to run them again with a larger budget if it
        // did.
        let rewind = self.cg.current() < self.cg.max();
        let before = if rewind {
            Before::Save
        } else {
            Before::Nothing
        };
        self.submit_steps("stepping", n, before).await?;
        let mut hits = self.cg.hits();
        let mut stats = self.check_async().await?;
        // A step stopped at the budget: the check has doubled it (at most
        // to the maximum, where no step is cut short); run the steps again
        // from where they started until none is.
        while rewind && self.cg.hits() != hits {
            hits = self.cg.hits();
            self.steps_recorded -= u64::from(n);
            self.submit_steps("stepping again with a larger CG budget", n, Before::Restore)
                .await?;
            stats = self.check_async().await?;
        }
        Ok(stats)
    }

    /// Records `n` steps, after what `before` says, in an encoder of their
    /// own and submits it; `what` names it in a device error.
    async fn submit_steps(&mut self, what: &str, n: u32, before: Before) -> Result<()> {
        let device = self.device.clone();
        guarded_async(&device, what, None, || {
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wgcloth.step"),
            });
            match before {
                Before::Nothing => {}
                Before::Save => self
                    .rewind
                    .get_or_insert_with(|| Rewind::new(&device, &self.buffers))
                    .save(&mut encoder, &self.buffers),
                Before::Restore => {
                    if let Some(copies) = &self.rewind {
                        copies.restore(&mut encoder, &self.buffers);
                    }
                }
            }
            self.encode_steps(&mut encoder, n);
            self.queue.submit([encoder.finish()]);
            Ok(())
        })
        .await
    }

    /// Reads the status words; an error names the first step whose state
    /// was not finite.
    ///
    /// It also sets the CG iteration budget — how many iterations each
    /// recorded step contains — to the largest count any step needed since
    /// the last check and a quarter more (at most the configured maximum;
    /// see `src/gpu/cg_budget.rs`). A window in which some step used the
    /// whole budget doubles it and is counted in
    /// [`StepStats::cg_budget_hits`] (such a step stopped with its residual
    /// above the tolerance; [`GpuSolver::step`] runs it again). With no check in between, or with
    /// [`GpuTuningMut::set_adaptive_cg_budget`](super::GpuTuningMut::set_adaptive_cg_budget)`(false)`,
    /// the budget never changes and every step may use the full maximum.
    ///
    /// Native only: in a browser, which cannot wait for a read-back, it is
    /// an error saying to await [`GpuSolver::check_async`].
    pub fn check(&mut self) -> Result<StepStats> {
        block_on("GpuSolver::check_async", self.check_async())
    }

    /// [`GpuSolver::check`] as a future: it resolves when the status words
    /// are read back (in a browser, when it has mapped them).
    pub async fn check_async(&mut self) -> Result<StepStats> {
        let bytes = readback::read_buffers_async(
            &self.device,
            &self.queue,
            &[(&self.buffers.status, 0, (layout::status::COUNT * 4) as u64)],
        )
        .await?;
        let mut status = self.decode_status(&bytes[0])?;
        if self.cg.update(status.cg_max_iterations) {
            // Restart the window: the next check sees only new steps.
            self.queue.write_buffer(
                &self.buffers.status,
                (layout::status::CG_MAX_ITERATIONS * 4) as u64,
                bytemuck::bytes_of(&0u32),
            );
        }
        status.cg_budget_hits = Some(self.cg.hits());
        Ok(status)
    }

    /// Turns the adaptive CG iteration budget on (the default) or off (every
    /// step records the configured maximum: results equal the CPU
    /// reference's exactly, at the cost of empty dispatches).
    pub(super) fn set_adaptive_cg_budget(&mut self, on: bool) {
        self.cg.set_adaptive(on);
    }

    /// CG iterations recorded per step at present (see
    /// [`GpuSolver::check`]).
    pub(super) fn cg_budget(&self) -> u32 {
        self.cg.current()
    }

    pub(super) fn dispatches_per_cg_iteration(&self) -> u32 {
        self.prepared.steps.per_cg_iteration()
    }

    fn decode_status(&self, bytes: &[u8]) -> Result<StepStats> {
        let words: &[u32] = bytemuck::cast_slice(bytes);
        decode_status(words, self.steps_recorded, self.dt, Some(self.cg.hits()))
    }

    /// Reads positions and velocities back (blocking); fails if the state
    /// stopped being finite at some step. Native only (see
    /// [`GpuSolver::read_state_async`]).
    pub fn read_state(&self) -> Result<GpuState> {
        block_on("GpuSolver::read_state_async", self.read_state_async())
    }

    /// [`GpuSolver::read_state`] as a future, for a browser's event loop.
    pub async fn read_state_async(&self) -> Result<GpuState> {
        let bytes = u64::from(self.params.particle_count) * 16;
        let parts = readback::read_buffers_async(
            &self.device,
            &self.queue,
            &[
                (&self.buffers.x, 0, bytes),
                (&self.buffers.v, 0, bytes),
                (&self.buffers.status, 0, (layout::status::COUNT * 4) as u64),
            ],
        )
        .await?;
        self.decode_status(&parts[2])?;
        Ok(GpuState::from_bytes(&parts[0], &parts[1]))
    }

    /// The position buffer: `particles` entries of `vec4<f32>` (xyz in m,
    /// w = inverse mass), usable as a vertex buffer with stride 16 and a
    /// `Float32x3` attribute at offset 0. Read it freely; change the state
    /// through [`GpuSolver::set_position`] and [`GpuSolver::set_pinned`]
    /// only (single-pass explicit steps read a snapshot of it that those
    /// mark stale).
    pub fn positions_buffer(&self) -> &wgpu::Buffer {
        &self.buffers.x
    }

    /// Vertex normals (`vec4<f32>`, xyz unit), valid after
    /// [`GpuSolver::encode_normals`].
    pub fn normals_buffer(&self) -> &wgpu::Buffer {
        &self.buffers.normals
    }

    /// Triangle indices (`u32`, three per triangle) as an index buffer.
    pub fn index_buffer(&self) -> &wgpu::Buffer {
        &self.buffers.indices
    }

    /// Number of indices in [`GpuSolver::index_buffer`].
    pub fn index_count(&self) -> u32 {
        self.params.triangle_count * 3
    }

    /// The buffers and range that draw the cloth (see [`DrawRange`]): all
    /// of [`GpuSolver::index_buffer`], from vertex 0.
    pub fn draw_range(&self) -> DrawRange<'_> {
        DrawRange {
            positions: self.positions_buffer(),
            normals: self.normals_buffer(),
            index_buffer: self.index_buffer(),
            indices: 0..self.index_count(),
            base_vertex: 0,
        }
    }

    /// Compute dispatches per step in the last [`GpuSolver::encode_steps`]
    /// call (all in one compute pass of one encoder, one submit).
    pub(super) fn dispatches_per_step(&self) -> f64 {
        let (d, s) = self.recorded.get();
        if s == 0 {
            0.0
        } else {
            f64::from(d) / f64::from(s)
        }
    }

    /// Particles.
    pub fn particle_count(&self) -> u32 {
        self.params.particle_count
    }

    /// Steps recorded so far.
    pub fn steps_recorded(&self) -> u64 {
        self.steps_recorded
    }

    /// Springs.
    pub fn spring_count(&self) -> u32 {
        self.model.springs.len() as u32
    }
}

#[cfg(test)]
mod tests {
    use super::{dense_fits, widen_step};
    use crate::budget::Counts;
    use crate::model::{ClothSpec, Model};
    use crate::params::{Integrator, Params};

    /// The dense filter of a cloth fits WebGPU's default binding until the
    /// cloth's `n² + n` words pass 128 MiB: an 80² cloth (6 400
    /// particles, 164 MB) does not, a 64² one (16.8 MB) does.
    #[test]
    fn the_dense_filter_fits_the_default_binding_up_to_its_size() {
        let params = Params {
            integrator: Integrator::SemiImplicit,
            ..Params::default()
        };
        let limits = wgpu::Limits::default();
        let fits = |side: usize| {
            let spec = ClothSpec {
                nx: side,
                ny: side,
                ..ClothSpec::default()
            };
            let model = Model::new(&spec, &params.springs).expect("a grid");
            dense_fits(&model, Counts::of_model(&model), &params, &limits)
        };
        assert!(fits(64));
        assert!(!fits(80));
    }

    #[test]
    fn device_step_counts_widen_past_the_32_bit_wrap() {
        assert_eq!(widen_step(7, 7), 7);
        assert_eq!(widen_step(5, 7), 5);
        let past = (1u64 << 32) + 3;
        assert_eq!(widen_step(3, past), past);
        assert_eq!(widen_step(u32::MAX, past), (1 << 32) - 1);
        assert_eq!(widen_step(2, 5 * (1 << 32) + 10), 5 * (1 << 32) + 2);
    }
}
