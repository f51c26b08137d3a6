//! The GPU solver: buffers, pipelines and the recording of steps.

use wgpu::util::DeviceExt;

use super::layout::{self, section, GpuParams, GpuSphere, GpuSpring, MAX_SPHERES};
use super::pipelines::{fixup_variant, Features, Pipelines};
use super::readback;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::params::{FilterMethod, Ground, Integrator, Params, Sphere, Wind};
use crate::real::Vec3;

/// Invocations per workgroup of every per-particle and per-spring kernel,
/// and so the block size of every reduction (the CPU reference reduces in
/// blocks of the same size to sum in the same order). 64 is a multiple of
/// every GPU's SIMD width and, on lavapipe, keeps both CPU cores busy down
/// to a 33 × 33 cloth (17 workgroups).
pub const WORKGROUP: u32 = crate::cpu::REDUCTION_BLOCK as u32;

/// Storage buffers one kernel binds (see `shaders/common/bindings.wgsl`).
const STORAGE_BUFFERS: u32 = 10;

/// Positions and velocities read back from the device.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuState {
    /// Positions [m].
    pub x: Vec<Vec3<f32>>,
    /// Velocities [m/s].
    pub v: Vec<Vec3<f32>>,
}

/// What the device reports about the steps it ran.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuStatus {
    /// Steps the device has run.
    pub steps: u64,
    /// CG iterations of the last implicit step.
    pub cg_iterations: u32,
    /// Largest CG iteration count of any step since the last check.
    pub cg_max_iterations: u32,
    /// Checks whose window had a step stop at the adaptive budget rather
    /// than at convergence (see [`GpuSolver::check`]).
    pub cg_budget_hits: u64,
    /// Fix-up passes run in the last step; when it stopped early, the last
    /// of them found nothing over-stretched.
    pub fixup_passes: u32,
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
    device: wgpu::Device,
    queue: wgpu::Queue,
    integrator: Integrator,
    particles: u32,
    springs: u32,
    triangles: u32,
    fixup_iterations: u32,
    cg_max_iterations: u32,
    /// CG iterations recorded per step (adapts at each status check).
    cg_budget: u32,
    adaptive_budget: bool,
    budget_hits: u64,
    params: GpuParams,
    params_buffer: wgpu::Buffer,
    x: wgpu::Buffer,
    v: wgpu::Buffer,
    normals: wgpu::Buffer,
    indices: wgpu::Buffer,
    status: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    pipelines: Pipelines,
    features: Features,
    steps_recorded: u64,
    dt: f64,
    /// The model with its current pins (a dense filter is rebuilt from it).
    model: Model,
    /// Dispatches recorded by the last `encode_steps`, and its steps.
    recorded: std::cell::Cell<(u32, u32)>,
    /// Scene-specialised kernels (the default) or the general ones.
    specialised: bool,
    /// The parameters with the current colliders, wind and gravity.
    host_params: Params,
    dense: wgpu::Buffer,
}

/// What the scene uses, for the kernel variants.
fn scene_features(model: &Model, params: &Params) -> Features {
    let colliders = params.ground.is_some() || !params.spheres.is_empty();
    Features {
        wind: params.wind.is_some(),
        ground: params.ground.is_some(),
        spheres: !params.spheres.is_empty(),
        filter: colliders || model.pinned_count() > 0,
        damping: params
            .springs
            .iter()
            .any(|k| k.stiffness > 0.0 && k.damping > 0.0),
    }
}

/// Uniform values when there is no wind (the kernels compile it out).
const NO_WIND: Wind = Wind {
    velocity: [0.0; 3],
    drag: 0.0,
    lift: 0.0,
};

/// Uniform values when there is no ground: the kernels compile it out,
/// and the general variant (see [`GpuSolver::set_specialised`]) never
/// reaches a plane this far down.
const NO_GROUND: Ground = Ground {
    height: -1e30,
    friction: 0.0,
};

/// Spheres as the uniform block holds them (the caller checks the count).
fn gpu_spheres(spheres: &[Sphere]) -> [GpuSphere; MAX_SPHERES] {
    let mut out = [GpuSphere::default(); MAX_SPHERES];
    for (g, s) in out.iter_mut().zip(spheres) {
        *g = GpuSphere {
            center: s.center.map(|c| c as f32),
            radius: s.radius as f32,
            friction: s.friction as f32,
            _pad: [0.0; 3],
        };
    }
    out
}

fn limit(name: &'static str, available: u64, needed: u64) -> Result<()> {
    if needed > available {
        Err(Error::DeviceLimit {
            limit: name,
            available,
            needed,
        })
    } else {
        Ok(())
    }
}

/// The semi-implicit filter as the GPU applies it: `Wᵀ` followed by the
/// filter order (`u32` bits), built on the host by the CPU reference's own
/// filter code in `f32`.
///
/// A cloth with more free particles than the dense crossover gets no
/// matrix: its filter is solved by CG on the device instead.
#[derive(Debug)]
struct SemiFilter {
    count: u32,
    words: Vec<f32>,
}

/// Relative tolerance of the semi-implicit filter's CG solve: a hundred
/// f32 epsilons, about where single-precision CG stops making progress.
pub const FILTER_CG_TOLERANCE: f64 = 1e-5;

/// Iteration cap of the semi-implicit filter's CG solve. The matrix is
/// constant and the solve warm-started, so after the first steps it needs
/// far fewer; the recorded budget adapts (see [`GpuSolver::check`]).
pub const FILTER_CG_MAX_ITERATIONS: u32 = 1000;

impl SemiFilter {
    fn new(model: &Model, params: &Params) -> Result<SemiFilter> {
        let sys = crate::cpu::System::<f32>::new(model, params);
        let grid = model.grid.as_ref().map(|g| (g.nx, g.ny));
        let fs = crate::cpu::filter::FilterSystem::new(&sys, grid);
        let dense = match params.semi_implicit.filter {
            FilterMethod::Dense => true,
            FilterMethod::Banded => false,
            FilterMethod::Auto => fs.len() <= crate::cpu::DENSE_FILTER_MAX_PARTICLES,
        };
        if !dense {
            return Ok(SemiFilter {
                count: 0,
                words: Vec::new(),
            });
        }
        let w = crate::cpu::filter::DenseFilter::<f32>::new(&fs).map_err(|_| {
            Error::InvalidParameter {
                key: "semi_implicit".into(),
                allowed: "a positive-definite filter matrix M − dt²H".into(),
                got: "a matrix that is not".into(),
            }
        })?;
        let n = fs.len();
        let m = w.matrix();
        let mut words = Vec::with_capacity(n * n + n);
        for q in 0..n {
            for k in 0..n {
                words.push(m[k * n + q]);
            }
        }
        words.extend(w.order().iter().map(|&p| f32::from_bits(p)));
        Ok(SemiFilter {
            count: n as u32,
            words,
        })
    }
}

impl GpuSolver {
    /// Builds the solver on the host's `device` and `queue`. Refuses, before
    /// allocating anything, invalid parameters and a cloth that exceeds the
    /// device's limits (the error names the limit and the size asked for).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
    ) -> Result<GpuSolver> {
        params.validate()?;
        let filter = match params.integrator {
            Integrator::SemiImplicit => Some(SemiFilter::new(model, params)?),
            _ => None,
        };
        let n = model.particle_count() as u64;
        let s = model.springs.len() as u64;
        let limits = device.limits();
        limit(
            "max_storage_buffers_per_shader_stage",
            limits.max_storage_buffers_per_shader_stage.into(),
            STORAGE_BUFFERS.into(),
        )?;
        let work_bytes = u64::from(section::COUNT) * n * 16;
        let dense_bytes = filter
            .as_ref()
            .filter(|f| !f.words.is_empty())
            .map_or(0, |_| (n * n + n) * 4);
        let biggest = work_bytes
            .max(s * 32)
            .max(s * 16 * u64::from(layout::SPRING_SECTIONS))
            .max(dense_bytes);
        limit(
            "max_storage_buffer_binding_size",
            limits.max_storage_buffer_binding_size,
            biggest,
        )?;
        limit("max_buffer_size", limits.max_buffer_size, biggest)?;
        let groups = n.max(s).div_ceil(u64::from(WORKGROUP));
        limit(
            "max_compute_workgroups_per_dimension",
            limits.max_compute_workgroups_per_dimension.into(),
            groups,
        )?;
        limit(
            "max_compute_workgroup_size_x",
            limits.max_compute_workgroup_size_x.into(),
            WORKGROUP.into(),
        )?;
        if params.spheres.len() > MAX_SPHERES {
            return Err(Error::InvalidParameter {
                key: "sphere".into(),
                allowed: format!("at most {MAX_SPHERES} spheres on the GPU backend"),
                got: params.spheres.len().to_string(),
            });
        }

        let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let solver = Self::build(device, queue, model, params, filter);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(e.to_string()));
        }
        solver
    }

    fn build(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
        filter: Option<SemiFilter>,
    ) -> Result<GpuSolver> {
        let n = model.particle_count() as u32;
        let partial_count = n.div_ceil(WORKGROUP);
        let semi_cg = filter.as_ref().is_some_and(|f| f.words.is_empty());
        let (cg_tolerance, cg_max_iterations) = if semi_cg {
            (FILTER_CG_TOLERANCE, FILTER_CG_MAX_ITERATIONS)
        } else {
            (params.implicit.tolerance, params.implicit.max_iterations)
        };

        // Topology: spring CSR (offsets, entries, then each entry's other
        // particle), triangle CSR, triangles, one u32 array.
        let mut topo: Vec<u32> = model.particle_springs.offsets.clone();
        let spring_adj_entries = topo.len() as u32;
        topo.extend(&model.particle_springs.entries);
        topo.extend(model.particle_springs.entries.iter().map(|&e| {
            let sp = &model.springs[(e >> 1) as usize];
            if e & 1 == 0 {
                sp.j
            } else {
                sp.i
            }
        }));
        let tri_adj_offsets = topo.len() as u32;
        topo.extend(&model.particle_triangles.offsets);
        let tri_adj_entries = topo.len() as u32;
        topo.extend(&model.particle_triangles.entries);
        let triangles = topo.len() as u32;
        topo.extend(model.triangles.iter().flatten());

        let gpu_springs: Vec<GpuSpring> = model
            .springs
            .iter()
            .map(|sp| {
                let m = params.spring(sp.kind);
                let max_len = match m.max_stretch {
                    Some(f) if params.fixup.iterations > 0 => (f * sp.rest) as f32,
                    _ => 0.0,
                };
                GpuSpring {
                    i: sp.i,
                    j: sp.j,
                    rest: sp.rest as f32,
                    k: m.stiffness as f32,
                    kd: m.damping as f32,
                    max_len,
                    _pad: [0; 2],
                }
            })
            .collect();

        let spheres = gpu_spheres(&params.spheres);
        let wind = params.wind.unwrap_or(NO_WIND);
        let ground = params.ground.unwrap_or(NO_GROUND);
        let gpu_params = GpuParams {
            gravity: params.gravity.map(|g| g as f32),
            dt: params.dt as f32,
            wind_velocity: wind.velocity.map(|c| c as f32),
            wind_drag: wind.drag as f32,
            wind_lift: wind.lift as f32,
            ground_height: ground.height as f32,
            ground_friction: ground.friction as f32,
            fixup_omega: params.fixup.omega as f32,
            particle_count: n,
            spring_count: model.springs.len() as u32,
            triangle_count: model.triangles.len() as u32,
            sphere_count: params.spheres.len() as u32,
            spring_adj_entries,
            tri_adj_offsets,
            tri_adj_entries,
            triangles,
            cg_tolerance_sq: (cg_tolerance * cg_tolerance) as f32,
            partial_count,
            filter_count: filter.as_ref().map_or(0, |f| f.count),
            torque_compensation: u32::from(
                params.semi_implicit.torque_compensation && model.pinned_count() == 0,
            ),
            spheres,
        };

        let x0: Vec<[f32; 4]> = model
            .rest_positions
            .iter()
            .zip(model.mass.iter().zip(&model.pinned))
            .map(|(p, (&m, &pinned))| {
                let w = if pinned { 0.0 } else { (1.0 / m) as f32 };
                [p[0] as f32, p[1] as f32, p[2] as f32, w]
            })
            .collect();
        let v0: Vec<[f32; 4]> = model
            .mass
            .iter()
            .map(|&m| [0.0, 0.0, 0.0, m as f32])
            .collect();

        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let zeroed = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage,
                mapped_at_creation: false,
            })
        };
        let params_buffer = init(
            "wgcloth.params",
            bytemuck::bytes_of(&gpu_params),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let springs_buffer = init(
            "wgcloth.springs",
            bytemuck::cast_slice(&gpu_springs),
            storage,
        );
        let topo_buffer = init("wgcloth.topo", bytemuck::cast_slice(&topo), storage);
        let x = init(
            "wgcloth.positions",
            bytemuck::cast_slice(&x0),
            storage | wgpu::BufferUsages::VERTEX,
        );
        let v = init("wgcloth.velocities", bytemuck::cast_slice(&v0), storage);
        let work = zeroed(
            "wgcloth.work",
            u64::from(section::COUNT) * u64::from(n) * 16,
            storage,
        );
        // The CG filter's constant blocks (m = 0, a = dt² k); the implicit
        // integrator overwrites this buffer every step.
        let mut blocks = vec![[0f32; 4]; layout::SPRING_SECTIONS as usize * gpu_springs.len()];
        if semi_cg {
            let dt2 = (params.dt * params.dt) as f32;
            for (b, s) in blocks.iter_mut().zip(&gpu_springs) {
                b[3] = dt2 * s.k;
            }
        }
        let spring_work = init(
            "wgcloth.spring_work",
            bytemuck::cast_slice(&blocks),
            storage,
        );
        let partials = zeroed(
            "wgcloth.partials",
            (u64::from(layout::PARTIAL_SLOTS) * u64::from(partial_count)
                + u64::from(layout::CG_SCALARS))
                * 4,
            storage,
        );
        let mut status0 = [0u32; layout::status::COUNT];
        status0[layout::status::BAD_STEP] = u32::MAX;
        status0[layout::status::BAD_PARTICLE] = u32::MAX;
        let status = init("wgcloth.status", bytemuck::cast_slice(&status0), storage);
        let normals = zeroed(
            "wgcloth.normals",
            u64::from(n) * 16,
            storage | wgpu::BufferUsages::VERTEX,
        );
        // Sized for every particle free, so that changing pins (which
        // rebuilds W) never needs a new buffer.
        let dense = match &filter {
            Some(f) if !f.words.is_empty() => {
                let all = u64::from(n) * u64::from(n) + u64::from(n);
                let buffer = zeroed("wgcloth.dense", all * 4, storage);
                queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&f.words));
                buffer
            }
            _ => zeroed("wgcloth.dense", 16, storage),
        };
        let indices = init(
            "wgcloth.indices",
            bytemuck::cast_slice(&model.triangles),
            wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
        );

        let storage_entry = |binding: u32, read_only: bool| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
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
        for (binding, read_only) in [
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
        ] {
            entries.push(storage_entry(binding, read_only));
        }
        let bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wgcloth.bindings"),
            entries: &entries,
        });
        let buffers = [
            &params_buffer,
            &springs_buffer,
            &topo_buffer,
            &x,
            &v,
            &work,
            &spring_work,
            &partials,
            &status,
            &normals,
            &dense,
        ];
        let bind_entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(k, b)| wgpu::BindGroupEntry {
                binding: k as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wgcloth.bindings"),
            layout: &bgl,
            entries: &bind_entries,
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wgcloth.pipeline_layout"),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        });

        let features = scene_features(model, params);
        let mut pipelines = Pipelines::new(layout);
        pipelines.ensure(device, params.integrator, features)?;
        queue.submit([]);

        Ok(GpuSolver {
            device: device.clone(),
            queue: queue.clone(),
            integrator: params.integrator,
            particles: n,
            springs: model.springs.len() as u32,
            triangles: model.triangles.len() as u32,
            fixup_iterations: if params.springs.iter().any(|s| s.max_stretch.is_some()) {
                params.fixup.iterations
            } else {
                0
            },
            cg_max_iterations,
            cg_budget: cg_max_iterations,
            adaptive_budget: true,
            budget_hits: 0,
            params: gpu_params,
            params_buffer,
            x,
            v,
            normals,
            indices,
            status,
            bind_group,
            pipelines,
            features,
            steps_recorded: 0,
            dt: params.dt,
            model: model.clone(),
            recorded: std::cell::Cell::new((0, 0)),
            specialised: true,
            host_params: params.clone(),
            dense,
        })
    }

    /// Dispatches `name` over `items` invocations (a one-invocation kernel,
    /// `@workgroup_size(1)`, is dispatched as one workgroup).
    fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, name: &str, items: u32) {
        if let Some(p) = self.pipelines.get(name, self.features) {
            let (d, s) = self.recorded.get();
            self.recorded.set((d + 1, s));
            pass.set_pipeline(p);
            let groups = if items == 1 {
                1
            } else {
                items.div_ceil(WORKGROUP)
            };
            pass.dispatch_workgroups(groups, 1, 1);
        }
    }

    /// Records `n` steps into `encoder` without submitting. All steps go
    /// into one compute pass.
    pub fn encode_steps(&mut self, encoder: &mut wgpu::CommandEncoder, n: u32) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wgcloth.steps"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        self.recorded.set((0, n));
        let plan = self.step_plan();
        for _ in 0..n {
            for &(name, items) in &plan {
                self.dispatch(&mut pass, name, items);
            }
        }
        self.steps_recorded += u64::from(n);
    }

    /// The dispatches of one step, in order: `(kernel variant, invocations)`.
    ///
    /// Only what the scene uses is recorded: no fix-up passes without a
    /// constrained spring kind or with zero iterations; no torque passes for
    /// a pinned cloth; without fix-up and wind the explicit integration and
    /// the step end are one fused kernel; wind, ground, spheres, pins and
    /// damping are compiled out of the kernels when absent (see
    /// [`super::pipelines`]); CG records the adaptive budget of iterations
    /// (see [`GpuSolver::check`]) and stops on the device. The fix-up, too,
    /// stops on the device once a pass moves nothing.
    pub fn step_plan(&self) -> Vec<(&'static str, u32)> {
        let (n, s) = (self.particles, self.springs);
        let mut plan = Vec::new();
        let cg = |plan: &mut Vec<(&'static str, u32)>| {
            // δ0, α, β and the convergence test are each reduced once, by a
            // one-invocation kernel, not by every workgroup.
            plan.push(("cg_init", n));
            plan.push(("cg_start", 1));
            for _ in 0..self.cg_budget {
                plan.extend([
                    ("cg_apply", n),
                    ("cg_alpha", 1),
                    ("cg_update", n),
                    ("cg_beta", 1),
                    ("cg_direction", n),
                ]);
            }
        };
        match self.integrator {
            Integrator::Implicit => {
                plan.push(("implicit_springs", s));
                plan.push(("implicit_prepare", n));
                cg(&mut plan);
                plan.push(("implicit_finish", n));
                return plan;
            }
            Integrator::Explicit => {
                plan.push(("spring_forces", s));
                if self.fused_explicit() {
                    plan.push(("explicit_integrate.fused", n));
                    return plan;
                }
                plan.push(("explicit_integrate", n));
            }
            Integrator::SemiImplicit => {
                plan.push(("spring_forces", s));
                if self.params.filter_count > 0 {
                    plan.push(("semi_rhs", n));
                    plan.push(("filter_dense", self.params.filter_count));
                } else {
                    plan.push(("semi_rhs.keep", n));
                    plan.push(("semi_cg_prepare", n));
                    cg(&mut plan);
                }
                if self.params.torque_compensation != 0 {
                    plan.extend([
                        ("torque_centre", n),
                        ("torque_moments", n),
                        ("torque_apply", n),
                    ]);
                }
                plan.push(("semi_integrate", n));
            }
        }
        for k in 0..self.fixup_iterations {
            plan.push((fixup_variant(k), n));
        }
        plan.push(("finish_step", n));
        plan
    }

    /// The step plan grouped by kernel, in order of first appearance:
    /// `(kernel, dispatches per step, invocations per dispatch)` — what
    /// `wgcloth run --verbose` prints.
    pub fn describe_step(&self) -> Vec<(&'static str, u32, u32)> {
        let mut out: Vec<(&'static str, u32, u32)> = Vec::new();
        for (name, items) in self.step_plan() {
            let kernel = name.split('.').next().unwrap_or(name);
            match out.iter_mut().find(|(k, _, _)| *k == kernel) {
                Some(entry) => entry.1 += 1,
                None => out.push((kernel, 1, items)),
            }
        }
        out
    }

    /// Explicit steps without fix-up or wind integrate and finish in one
    /// kernel (it then reads no other particle's state, so it may write
    /// its own in place).
    fn fused_explicit(&self) -> bool {
        self.integrator == Integrator::Explicit && self.fixup_iterations == 0 && !self.features.wind
    }

    /// Records the vertex-normal pass (for rendering; stepping never needs
    /// it).
    pub fn encode_normals(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wgcloth.normals"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        self.dispatch(&mut pass, "normals", self.particles);
    }

    /// Records and submits `n` steps in one encoder, then checks the
    /// device's status word (one small read-back per call, none per step).
    pub fn step(&mut self, n: u32) -> Result<GpuStatus> {
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wgcloth.step"),
            });
        self.encode_steps(&mut encoder, n);
        self.queue.submit([encoder.finish()]);
        self.check()
    }

    /// Reads the status words; an error names the first step whose state
    /// was not finite.
    ///
    /// It also sets the CG iteration budget — how many iterations each
    /// recorded step contains — to twice the largest count any step needed
    /// since the last check, plus 16 (at most the configured maximum). A
    /// tighter margin (1.25× + 4 was tried) cut solves short on the test
    /// scenes for a ~5 % gain. Iterations past convergence do no work, but on some devices
    /// (lavapipe) even an empty dispatch costs tens of microseconds, so a
    /// budget of 200 for a solve that takes 30 would dominate the step. A
    /// window in which some step used the whole budget restores the full
    /// maximum and is counted in [`GpuStatus::cg_budget_hits`] (such a step
    /// stopped with its residual above the tolerance). With no check in
    /// between, or with [`GpuSolver::set_adaptive_cg_budget`]`(false)`, the
    /// budget never changes and every step may use the full maximum.
    pub fn check(&mut self) -> Result<GpuStatus> {
        let bytes = readback::read_buffers(
            &self.device,
            &self.queue,
            &[(&self.status, 0, (layout::status::COUNT * 4) as u64)],
        )?;
        let mut status = self.decode_status(&bytes[0])?;
        let used = status.cg_max_iterations;
        if self.adaptive_budget && used > 0 {
            if used >= self.cg_budget && self.cg_budget < self.cg_max_iterations {
                self.budget_hits += 1;
            }
            self.cg_budget = if used >= self.cg_budget {
                self.cg_max_iterations
            } else {
                (2 * used + 16).min(self.cg_max_iterations)
            };
            // Restart the window: the next check sees only new steps.
            self.queue.write_buffer(
                &self.status,
                (layout::status::CG_MAX_ITERATIONS * 4) as u64,
                bytemuck::bytes_of(&0u32),
            );
        }
        status.cg_budget_hits = self.budget_hits;
        Ok(status)
    }

    /// Turns the adaptive CG iteration budget on (the default) or off (every
    /// step records the configured maximum: results equal the CPU
    /// reference's exactly, at the cost of empty dispatches).
    pub fn set_adaptive_cg_budget(&mut self, on: bool) {
        self.adaptive_budget = on;
        if !on {
            self.cg_budget = self.cg_max_iterations;
        }
    }

    /// CG iterations recorded per step at present (see
    /// [`GpuSolver::check`]).
    pub fn cg_budget(&self) -> u32 {
        self.cg_budget
    }

    fn decode_status(&self, bytes: &[u8]) -> Result<GpuStatus> {
        let words: &[u32] = bytemuck::cast_slice(bytes);
        let bad = words[layout::status::BAD_STEP];
        if bad != u32::MAX {
            return Err(Error::NonFinite {
                step: u64::from(bad),
                time: f64::from(bad) * self.dt,
                particle: words[layout::status::BAD_PARTICLE] as usize,
            });
        }
        Ok(GpuStatus {
            steps: u64::from(words[layout::status::STEP]),
            cg_iterations: words[layout::status::CG_ITERATIONS],
            cg_max_iterations: words[layout::status::CG_MAX_ITERATIONS],
            cg_budget_hits: self.budget_hits,
            fixup_passes: words[layout::status::FIXUP_PASSES],
        })
    }

    /// Reads positions and velocities back (blocking); fails if the state
    /// stopped being finite at some step.
    pub fn read_state(&self) -> Result<GpuState> {
        let bytes = u64::from(self.particles) * 16;
        let parts = readback::read_buffers(
            &self.device,
            &self.queue,
            &[
                (&self.x, 0, bytes),
                (&self.v, 0, bytes),
                (&self.status, 0, (layout::status::COUNT * 4) as u64),
            ],
        )?;
        self.decode_status(&parts[2])?;
        let unpack = |b: &[u8]| -> Vec<Vec3<f32>> {
            bytemuck::cast_slice::<u8, [f32; 4]>(b)
                .iter()
                .map(|p| Vec3::new(p[0], p[1], p[2]))
                .collect()
        };
        Ok(GpuState {
            x: unpack(&parts[0]),
            v: unpack(&parts[1]),
        })
    }

    /// The position buffer: `particles` entries of `vec4<f32>` (xyz in m,
    /// w = inverse mass), usable as a vertex buffer with stride 16 and a
    /// `Float32x3` attribute at offset 0.
    pub fn positions_buffer(&self) -> &wgpu::Buffer {
        &self.x
    }

    /// Vertex normals (`vec4<f32>`, xyz unit), valid after
    /// [`GpuSolver::encode_normals`].
    pub fn normals_buffer(&self) -> &wgpu::Buffer {
        &self.normals
    }

    /// Triangle indices (`u32`, three per triangle) as an index buffer.
    pub fn index_buffer(&self) -> &wgpu::Buffer {
        &self.indices
    }

    /// Number of indices in [`GpuSolver::index_buffer`].
    pub fn index_count(&self) -> u32 {
        self.triangles * 3
    }

    /// Compute dispatches per step in the last [`GpuSolver::encode_steps`]
    /// call (all in one compute pass of one encoder, one submit).
    pub fn dispatches_per_step(&self) -> f64 {
        let (d, s) = self.recorded.get();
        if s == 0 {
            0.0
        } else {
            f64::from(d) / f64::from(s)
        }
    }

    /// Particles.
    pub fn particle_count(&self) -> u32 {
        self.particles
    }

    /// Steps recorded so far.
    pub fn steps_recorded(&self) -> u64 {
        self.steps_recorded
    }

    /// Springs.
    pub fn spring_count(&self) -> u32 {
        self.springs
    }

    /// Changes gravity [m/s²] from the next recorded step on.
    pub fn set_gravity(&mut self, gravity: [f64; 3]) -> Result<()> {
        let mut p = self.host_params.clone();
        p.gravity = gravity;
        p.validate()?;
        self.host_params = p;
        self.params.gravity = gravity.map(|g| g as f32);
        self.upload_params();
        Ok(())
    }

    /// Changes the wind (`None`: no wind) from the next recorded step on.
    /// Turning wind on or off switches to the matching kernel variants
    /// (compiled once, then cached).
    pub fn set_wind(&mut self, wind: Option<Wind>) -> Result<()> {
        let mut p = self.host_params.clone();
        p.wind = wind;
        p.validate()?;
        self.host_params = p;
        let w = wind.unwrap_or(NO_WIND);
        self.params.wind_velocity = w.velocity.map(|c| c as f32);
        self.params.wind_drag = w.drag as f32;
        self.params.wind_lift = w.lift as f32;
        self.update_features()
    }

    /// Changes the ground plane (`None`: no ground).
    pub fn set_ground(&mut self, ground: Option<Ground>) -> Result<()> {
        let mut p = self.host_params.clone();
        p.ground = ground;
        p.validate()?;
        self.host_params = p;
        let g = ground.unwrap_or(NO_GROUND);
        self.params.ground_height = g.height as f32;
        self.params.ground_friction = g.friction as f32;
        self.update_features()
    }

    /// Replaces the sphere colliders (at most [`MAX_SPHERES`]); a game
    /// moving a ball calls this every frame.
    pub fn set_spheres(&mut self, spheres: &[Sphere]) -> Result<()> {
        if spheres.len() > MAX_SPHERES {
            return Err(Error::InvalidParameter {
                key: "sphere".into(),
                allowed: format!("at most {MAX_SPHERES} spheres on the GPU backend"),
                got: spheres.len().to_string(),
            });
        }
        let mut p = self.host_params.clone();
        p.spheres = spheres.to_vec();
        p.validate()?;
        self.host_params = p;
        self.params.spheres = gpu_spheres(spheres);
        self.params.sphere_count = spheres.len() as u32;
        self.update_features()
    }

    /// Moves particle `p` to `position` [m] (for a pinned particle: a game
    /// dragging a corner). Its velocity is left as it is.
    pub fn set_position(&mut self, p: usize, position: [f32; 3]) -> Result<()> {
        self.check_particle(p)?;
        self.queue
            .write_buffer(&self.x, (p * 16) as u64, bytemuck::cast_slice(&position));
        Ok(())
    }

    /// Pins (`true`) or releases (`false`) particle `p`. A newly pinned
    /// particle stops. A semi-implicit solver with the dense filter rebuilds
    /// its filter on the host (the pins are constrained inside it).
    pub fn set_pinned(&mut self, p: usize, pinned: bool) -> Result<()> {
        self.check_particle(p)?;
        if self.model.pinned[p] == pinned {
            return Ok(());
        }
        self.model.pinned[p] = pinned;
        let inverse_mass = if pinned {
            0.0
        } else {
            (1.0 / self.model.mass[p]) as f32
        };
        let base = (p * 16) as u64;
        self.queue
            .write_buffer(&self.x, base + 12, bytemuck::bytes_of(&inverse_mass));
        if pinned {
            self.queue
                .write_buffer(&self.v, base, bytemuck::cast_slice(&[0f32; 3]));
        }
        self.params.torque_compensation = u32::from(
            self.host_params.semi_implicit.torque_compensation && self.model.pinned_count() == 0,
        );
        if self.params.filter_count > 0 {
            let filter = SemiFilter::new(&self.model, &self.host_params)?;
            self.params.filter_count = filter.count;
            self.queue
                .write_buffer(&self.dense, 0, bytemuck::cast_slice(&filter.words));
        }
        self.update_features()
    }

    fn check_particle(&self, p: usize) -> Result<()> {
        if p < self.particles as usize {
            Ok(())
        } else {
            Err(Error::InvalidParameter {
                key: "particle".into(),
                allowed: format!("an index below {}", self.particles),
                got: p.to_string(),
            })
        }
    }

    /// With `false`, records the general kernels — every feature compiled
    /// in, absent ones made inert by their parameters (zero wind, no
    /// spheres, a ground out of reach, free filters, zero damping) — and no
    /// fused passes: for tests and benchmarks of what specialisation saves.
    /// With `true` (the default), the scene's own variants.
    pub fn set_specialised(&mut self, on: bool) -> Result<()> {
        self.specialised = on;
        self.update_features()
    }

    /// Switches to the kernel variants of the current scene (compiling any
    /// not cached yet) and uploads the parameters.
    fn update_features(&mut self) -> Result<()> {
        let features = if self.specialised {
            scene_features(&self.model, &self.host_params)
        } else {
            Features {
                wind: true,
                ground: true,
                spheres: true,
                filter: true,
                damping: true,
            }
        };
        self.pipelines
            .ensure(&self.device, self.integrator, features)?;
        self.features = features;
        self.upload_params();
        Ok(())
    }

    fn upload_params(&self) {
        self.queue
            .write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
    }
}
