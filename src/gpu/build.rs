//! Building a [`GpuSolver`]: what the host uploads (topology, springs,
//! the uniform block, the initial state), each built by a function of its
//! own, then the buffers and the step plan.

use super::buffers::{ClothBuffers, Uploads, UPLOAD};
use super::cg_budget::CgBudget;
use super::grid::{GridBlock, GridLayout};
use super::kernels::GpuKernels;
use super::layout::{torque_bits, GpuParams, GpuSpring};
use super::path::{PathChoice, StepPath};
use super::semi_filter::{SemiFilter, FILTER_CG_MAX_ITERATIONS, FILTER_CG_TOLERANCE};
use super::solver::{
    compiled_features, gpu_capsules, gpu_mesh_colliders, gpu_spheres, plan_inputs, scene_features,
    GpuSolver, Prepared, NO_GROUND, NO_WIND,
};
use crate::aggregation::Aggregation;
use crate::budget::{try_collect, try_with_capacity};
use crate::diagnostics::Motion;
use crate::error::Result;
use crate::kernel_config::{integrator, partials, spring_work, status, work, WORKGROUP};
use crate::model::Model;
use crate::params::{Integrator, Params, SpringParams};
use crate::sdf::{DistanceGrid, MeshCollider};
use crate::self_collision::SelfCollisionR;
use std::sync::Arc;

/// Word offsets of the parts of `topo` after the spring adjacency offsets.
struct TopoOffsets {
    spring_adj_entries: u32,
    tri_adj_offsets: u32,
    tri_adj_entries: u32,
    triangles: u32,
}

/// Topology as one `u32` array: spring CSR (offsets, entries — with
/// `slot_of` for spring indices — then each entry's other particle),
/// triangle CSR, triangles.
fn topology(model: &Model, slot_of: impl Fn(usize) -> u32) -> Result<(Vec<u32>, TopoOffsets)> {
    let words = 2 * model.particle_springs.entries.len()
        + model.particle_springs.offsets.len()
        + model.particle_triangles.offsets.len()
        + model.particle_triangles.entries.len()
        + 3 * model.triangles.len();
    let mut topo: Vec<u32> = try_with_capacity(words, UPLOAD)?;
    topo.extend(&model.particle_springs.offsets);
    let spring_adj_entries = topo.len() as u32;
    let entries = &model.particle_springs.entries;
    topo.extend(
        entries
            .iter()
            .map(|&e| slot_of((e >> 1) as usize) << 1 | (e & 1)),
    );
    topo.extend(entries.iter().map(|&e| {
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
    let offsets = TopoOffsets {
        spring_adj_entries,
        tri_adj_offsets,
        tri_adj_entries,
        triangles,
    };
    Ok((topo, offsets))
}

/// A spring per slot: each spring at `slot_of` its index; unused grid
/// slots hold a spring of zero stiffness from the owner to itself (no
/// kernel reaches them; see `super::grid`).
fn device_springs(
    model: &Model,
    params: &Params,
    slots: usize,
    slot_of: impl Fn(usize) -> u32,
) -> Result<Vec<GpuSpring>> {
    let owner = |slot: usize| (slot % model.particle_count().max(1)) as u32;
    let mut springs: Vec<GpuSpring> = try_collect(
        (0..slots).map(|slot| GpuSpring {
            i: owner(slot),
            j: owner(slot),
            ..GpuSpring::default()
        }),
        UPLOAD,
    )?;
    for (s, sp) in model.springs.iter().enumerate() {
        let c = model.spring_constants(s, params);
        springs[slot_of(s) as usize] = GpuSpring {
            i: sp.i,
            j: sp.j,
            rest: sp.rest as f32,
            k: c.k as f32,
            kd: c.kd as f32,
            max_len: model.fixup_limit(s, params) as f32,
            _pad: [0; 2],
        };
    }
    Ok(springs)
}

/// Positions with inverse masses (0: pinned), and zero velocities with
/// masses.
type InitialState = (Vec<[f32; 4]>, Vec<[f32; 4]>);

/// The initial state as uploaded.
fn initial_state(model: &Model) -> Result<InitialState> {
    let x = try_collect(
        model
            .rest_positions
            .iter()
            .zip(model.mass.iter().zip(&model.pinned))
            .map(|(p, (&m, &pinned))| {
                let w = if pinned { 0.0 } else { (1.0 / m) as f32 };
                [p[0] as f32, p[1] as f32, p[2] as f32, w]
            }),
        UPLOAD,
    )?;
    let v = try_collect(
        model.mass.iter().map(|&m| [0.0, 0.0, 0.0, m as f32]),
        UPLOAD,
    )?;
    Ok((x, v))
}

/// What [`uniform_block`] needs besides the model and parameters.
struct Shape<'a> {
    grid: Option<&'a GridLayout>,
    block: GridBlock,
    slots: u32,
    topo: TopoOffsets,
    filter: Option<&'a SemiFilter>,
    /// The semi-implicit filter is solved by CG.
    semi_cg: bool,
    cg_tolerance: f64,
    /// Most CG iterations per step.
    cg_max_iterations: u32,
    fixup_iterations: u32,
    /// Self-collision in the GPU's precision (the `f32` mirror's values).
    self_collision: Option<&'a SelfCollisionR<f32>>,
    /// Each mesh collider's grid header, a `vec4` index from the grids'
    /// first word (see [`mesh_grids`]).
    grids: Vec<u32>,
}

/// The linear bending operator's rows as `model` holds them (see
/// `shaders/common/bending.wgsl`): the row offsets (`N + 1`), the columns,
/// then each coefficient as the bits of the `f32` the CPU mirror holds
/// ([`crate::cpu::BendingR`]); empty without one.
fn bending_words(model: &Model) -> Result<Vec<u32>> {
    let Some(b) = &model.bending else {
        return Ok(Vec::new());
    };
    let len = b.offsets.len() + b.columns.len() + b.coefficients.len();
    let mut words: Vec<u32> = try_with_capacity(len, UPLOAD)?;
    words.extend(&b.offsets);
    words.extend(&b.columns);
    words.extend(b.coefficients.iter().map(|&q| (q as f32).to_bits()));
    Ok(words)
}

/// The bending model's uniform words: `β` and `dt² + dt β` as the CPU
/// mirror rounds them ([`crate::cpu::BendingR`]), and the word indices of
/// its rows relative to its first word (`ClothArrays::place` makes them
/// absolute); zero without one.
fn bending_uniform(model: &Model, dt: f64) -> ([f32; 4], [u32; 4]) {
    let Some(b) = &model.bending else {
        return ([0.0; 4], [0; 4]);
    };
    let columns = b.offsets.len() as u32;
    let coefficients = columns + b.columns.len() as u32;
    (
        [
            b.damping as f32,
            (dt * dt + dt * b.damping) as f32,
            0.0,
            0.0,
        ],
        [0, columns, coefficients, 0],
    )
}

/// The integrator as the kernels know it (`params.integrator`).
pub(crate) fn integrator_code(i: Integrator) -> u32 {
    match i {
        Integrator::Explicit => integrator::EXPLICIT,
        Integrator::Implicit => integrator::IMPLICIT,
        Integrator::SemiImplicit => integrator::SEMI_IMPLICIT,
    }
}

/// Fix-up passes per step: none without a constrained spring kind.
pub(super) fn fixup_iterations(params: &Params) -> u32 {
    if params.springs.iter().any(|s| s.max_stretch.is_some()) {
        params.fixup.iterations
    } else {
        0
    }
}

/// The uniform block of `model` under `params`.
fn uniform_block(model: &Model, params: &Params, shape: Shape<'_>) -> GpuParams {
    let kind = |f: fn(&SpringParams) -> f64| {
        let k = params.springs.map(|m| f(&m) as f32);
        // The fourth stays 0: kind_k's is the kernels' opaque zero.
        [k[0], k[1], k[2], 0.0]
    };
    let (grid_words, rest, max_len) = match shape.grid {
        Some(g) => (
            [g.nx, g.ny, g.kinds, shape.block.count(g.nx, g.ny)],
            g.rest,
            g.max_len,
        ),
        None => ([0; 4], [0.0; 6], [0.0; 6]),
    };
    let n = model.particle_count() as u32;
    let wind = params.wind.unwrap_or(NO_WIND);
    let ground = params.ground.unwrap_or(NO_GROUND);
    let dt2 = (params.dt * params.dt) as f32;
    let (bending, bending_rows) = bending_uniform(model, params.dt);
    let coarse = Aggregation::for_scene(model, params);
    GpuParams {
        gravity: params.gravity.as_vec3().to_array(),
        dt: params.dt as f32,
        wind_velocity: wind.velocity.as_vec3().to_array(),
        wind_drag: wind.drag as f32,
        wind_lift: wind.lift as f32,
        ground_height: ground.height as f32,
        ground_friction: ground.friction as f32,
        fixup_omega: params.fixup.omega as f32,
        particle_count: n,
        spring_count: shape.slots,
        triangle_count: model.triangles.len() as u32,
        sphere_count: params.spheres.len() as u32,
        spring_adj_entries: shape.topo.spring_adj_entries,
        tri_adj_offsets: shape.topo.tri_adj_offsets,
        tri_adj_entries: shape.topo.tri_adj_entries,
        triangles: shape.topo.triangles,
        cg_tolerance_sq: (shape.cg_tolerance * shape.cg_tolerance) as f32,
        partial_count: n.div_ceil(WORKGROUP),
        filter_count: shape.filter.map_or(0, |f| f.count),
        torque_compensation: torque_bits(
            params.semi_implicit.torque_compensation,
            model.pinned_count(),
        ),
        particle_base: 0,
        spring_base: 0,
        topo_base: 0,
        work_base: 0,
        spring_work_base: 0,
        partial_base: 0,
        status_base: 0,
        dense_base: 0,
        integrator: integrator_code(params.integrator),
        fixup_iterations: shape.fixup_iterations,
        cg_max_iterations: shape.cg_max_iterations,
        features: scene_features(model, params, None).bits(),
        grid: grid_words,
        grid_rest_a: [rest[0], rest[1], rest[2], rest[3]],
        grid_rest_b: [rest[4], rest[5], 0.0, 0.0],
        grid_max_a: [max_len[0], max_len[1], max_len[2], max_len[3]],
        grid_max_b: [max_len[4], max_len[5], 0.0, 0.0],
        kind_k: kind(|m| m.stiffness),
        kind_kd: kind(|m| m.damping),
        kind_a: if shape.semi_cg {
            kind(|m| m.stiffness).map(|k| dt2 * k)
        } else {
            [0.0; 4]
        },
        coarse: coarse.as_ref().map_or([0; 4], |a| {
            let first = a.pieces()[0];
            [first.nx, first.ny, a.count(0), a.count(1)].map(|c| c as u32)
        }),
        coarse_world: [
            coarse.as_ref().map_or(0, |a| a.pieces().len() as u32),
            0,
            0,
            0,
        ],
        coarse_pieces: {
            let mut words = [[0; 4]; 2 * crate::aggregation::MAX_PIECES];
            for (k, p) in coarse.iter().flat_map(|a| a.pieces()).enumerate() {
                words[2 * k] = [p.nx, p.ny, p.first, p.level1].map(|c| c as u32);
                words[2 * k + 1] = [p.level2 as u32, 0, 0, 0];
            }
            words
        },
        motion: [params.capsules.len() as u32, 0, 0, 0],
        self_collision: shape
            .self_collision
            .map_or([0.0; 4], |c| [c.thickness, c.friction, c.cap, c.inv_cell]),
        // The rest positions' place is set by `ClothArrays::place`.
        self_grid: shape.self_collision.map_or([0; 4], |c| {
            [c.iterations, c.table as u32, c.reference as u32, 0]
        }),
        spheres: gpu_spheres(&params.spheres),
        capsules: gpu_capsules(&params.capsules),
        mesh: [params.mesh_colliders.len() as u32, 0, 0, 0],
        // The grids' places are made absolute by `ClothArrays::place`.
        meshes: gpu_mesh_colliders(&params.mesh_colliders, &shape.grids),
        // The rows' places are made absolute by `ClothArrays::place`.
        bending,
        bending_rows,
    }
}

/// The mesh colliders' grids as `model` holds them: each distinct grid (a
/// grid shared by colliders is stored once) a header of two `vec4` — origin
/// \[m\] and cell \[m\] as `f32` bits, then its lattice points along x, y
/// and z — and its samples' bits, padded to a whole `vec4`. Returns the
/// words and each collider's header (a `vec4` index from the first word).
pub(crate) fn mesh_grids(colliders: &[MeshCollider]) -> Result<(Vec<u32>, Vec<u32>)> {
    let mut words: Vec<u32> = try_with_capacity(mesh_grid_words(colliders) as usize, UPLOAD)?;
    let mut placed: Vec<(&Arc<DistanceGrid>, u32)> = Vec::new();
    let mut at = Vec::with_capacity(colliders.len());
    for m in colliders {
        if let Some((_, h)) = placed.iter().find(|(g, _)| Arc::ptr_eq(g, &m.grid)) {
            at.push(*h);
            continue;
        }
        let g = &m.grid;
        let head = (words.len() / 4) as u32;
        words.extend(g.origin.map(f32::to_bits));
        words.push(g.cell.to_bits());
        words.extend(g.dims);
        words.push(0);
        words.extend(g.samples.iter().map(|s| s.to_bits()));
        words.resize(words.len().next_multiple_of(4), 0);
        placed.push((g, head));
        at.push(head);
    }
    Ok((words, at))
}

/// Words of [`mesh_grids`]: what the budget and the device limits count.
pub(crate) fn mesh_grid_words(colliders: &[MeshCollider]) -> u64 {
    let mut seen: Vec<&Arc<DistanceGrid>> = Vec::new();
    let mut words = 0;
    for m in colliders {
        if !seen.iter().any(|g| Arc::ptr_eq(g, &m.grid)) {
            seen.push(&m.grid);
            words += 8 + (m.grid.samples.len() as u64).next_multiple_of(4);
        }
    }
    words
}

/// What the host uploads for a cloth, built from its model and
/// parameters: a lone solver's buffers hold it as it is; a batch moves it
/// to the cloth's offsets (`src/gpu/batch/table.rs`).
#[derive(Debug)]
pub(crate) struct ClothArrays {
    /// The uniform block (all bases zero).
    pub params: GpuParams,
    /// A spring per slot.
    pub springs: Vec<GpuSpring>,
    /// Adjacency and triangles.
    pub topo: Vec<u32>,
    /// Positions and inverse masses.
    pub x: Vec<[f32; 4]>,
    /// Velocities and masses.
    pub v: Vec<[f32; 4]>,
    /// The dense semi-implicit filter (empty without one).
    pub dense: Vec<f32>,
    /// Self-collision's rest positions, in exclusion radii (empty
    /// without it).
    pub rest: Vec<[f32; 4]>,
    /// The mesh colliders' grids ([`mesh_grids`]; empty without them).
    pub grids: Vec<u32>,
    /// The linear bending operator's rows ([`bending_words`]; empty
    /// without one).
    pub bending: Vec<u32>,
}

/// `u32` words of a spring record in `model` (two `vec4<u32>`).
const SPRING_WORDS: u64 = (std::mem::size_of::<GpuSpring>() / 4) as u64;

impl ClothArrays {
    /// Spring records in `model` (slots).
    fn spring_count(&self) -> u64 {
        self.springs.len() as u64
    }

    /// Words the dense filter may take: sized for every particle free, so
    /// that changing pins (which rebuilds it) never needs more; none
    /// without a dense filter.
    fn dense_capacity(&self) -> u64 {
        if self.dense.is_empty() {
            return 0;
        }
        let n = u64::from(self.params.particle_count);
        n * n + n
    }

    /// `vec4` entries of the cloth's part of `model`: its spring records,
    /// `topo` and the dense filter, as `u32` words, padded to a whole
    /// `vec4` so the next cloth's records start aligned.
    pub(crate) fn model_len(&self) -> u64 {
        let words = SPRING_WORDS * self.spring_count()
            + self.rest_words()
            + self.grids.len() as u64
            + self.topo.len() as u64
            + self.bending.len() as u64;
        (words + self.dense_capacity()).div_ceil(4)
    }

    /// `u32` words of self-collision's rest positions in `model`.
    fn rest_words(&self) -> u64 {
        4 * self.rest.len() as u64
    }

    /// Words of the cloth's part of `status`: its status words, then with
    /// self-collision a counter per bucket (see `sc_counter` in
    /// `shaders/common/self_collision.wgsl`).
    pub(crate) fn status_len(&self) -> u64 {
        status::COUNT as u64
            + if self.rest.is_empty() {
                0
            } else {
                u64::from(self.params.self_grid[1])
            }
    }

    /// `vec4` entries of the cloth's part of `work`: the per-particle
    /// sections, the per-spring sections, the reduction partials and the
    /// CG scalars (one per `vec4`, see `partial` in
    /// `shaders/common/layout.wgsl`).
    pub(crate) fn work_len(&self) -> u64 {
        let n = u64::from(self.params.particle_count);
        u64::from(work::COUNT) * n
            + u64::from(spring_work::COUNT) * self.spring_count()
            + partial_count(n)
    }

    /// The cloth's part of `model` as uploaded: the spring records,
    /// self-collision's rest positions, the mesh colliders' grids, `topo`,
    /// the bending operator's rows, the dense filter's bits (its unused
    /// capacity is left out: a new buffer is zeroed, and no kernel reads
    /// past the filter).
    pub(crate) fn model_words(&self) -> Result<Vec<u32>> {
        let springs: &[u32] = bytemuck::cast_slice(&self.springs);
        let rest: &[u32] = bytemuck::cast_slice(&self.rest);
        let len = springs.len()
            + rest.len()
            + self.grids.len()
            + self.topo.len()
            + self.bending.len()
            + self.dense.len();
        let mut words: Vec<u32> = try_with_capacity(len, UPLOAD)?;
        words.extend_from_slice(springs);
        words.extend_from_slice(rest);
        words.extend_from_slice(&self.grids);
        words.extend_from_slice(&self.topo);
        words.extend_from_slice(&self.bending);
        words.extend(self.dense.iter().map(|w| w.to_bits()));
        Ok(words)
    }

    /// Places the cloth's parts of `model` at `vec4` entry `model_at` and
    /// of `work` at `vec4` entry `work_at` (a lone cloth: both 0): the
    /// bases and `topo` offsets of its parameters (built relative to its
    /// own arrays) become indices into the shared buffers, the contract of
    /// `shaders/common/layout.wgsl`.
    pub(crate) fn place(&mut self, model_at: u64, work_at: u64) {
        let n = u64::from(self.params.particle_count);
        let s = self.spring_count();
        let rest_at = 4 * model_at + SPRING_WORDS * s;
        let grids_at = rest_at + self.rest_words();
        let topo_at = (grids_at + self.grids.len() as u64) as u32;
        let p = &mut self.params;
        p.spring_base = model_at as u32;
        p.self_grid[3] = (rest_at / 4) as u32;
        for m in &mut p.meshes[..p.mesh[0] as usize] {
            m.grid += (grids_at / 4) as u32;
        }
        p.topo_base = topo_at;
        p.spring_adj_entries += topo_at;
        p.tri_adj_offsets += topo_at;
        p.tri_adj_entries += topo_at;
        p.triangles += topo_at;
        let bending_at = topo_at + self.topo.len() as u32;
        if !self.bending.is_empty() {
            for w in &mut p.bending_rows[..3] {
                *w += bending_at;
            }
        }
        p.dense_base = bending_at + self.bending.len() as u32;
        let spring_work_at = work_at + u64::from(work::COUNT) * n;
        p.work_base = work_at as u32;
        p.spring_work_base = spring_work_at as u32;
        p.partial_base = (spring_work_at + u64::from(spring_work::COUNT) * s) as u32;
    }
}

/// Reduction partials and CG scalars of a cloth of `n` particles (see
/// [`crate::kernel_config::partials`]).
pub(crate) fn partial_count(n: u64) -> u64 {
    u64::from(partials::SLOTS) * n.div_ceil(u64::from(WORKGROUP)) + u64::from(partials::CG_SCALARS)
}

/// The arrays of `model` under `params` with its semi-implicit `filter`,
/// in `grid` layout (`None`: general) gathered by `block`.
pub(super) fn cloth_arrays(
    model: &Model,
    params: &Params,
    filter: Option<SemiFilter>,
    grid: Option<&GridLayout>,
    block: GridBlock,
) -> Result<ClothArrays> {
    let semi_cg = filter.as_ref().is_some_and(|f| f.words.is_empty());
    let self_collision = SelfCollisionR::<f32>::of(model, params);
    let (cg_tolerance, cg_max_iterations) = if semi_cg {
        (FILTER_CG_TOLERANCE, FILTER_CG_MAX_ITERATIONS)
    } else {
        (params.implicit.tolerance, params.implicit.max_iterations)
    };
    // Where each spring lives on the device: its slot in grid layout,
    // else its index.
    let slot_of = |s: usize| grid.map_or(s as u32, |g| g.slot[s]);
    let slots = grid.map_or(model.springs.len(), GridLayout::slots);
    let (topo, offsets) = topology(model, slot_of)?;
    let springs = device_springs(model, params, slots, slot_of)?;
    let (x, v) = initial_state(model)?;
    let (grids, grid_at) = mesh_grids(&params.mesh_colliders)?;
    let shape = Shape {
        grid,
        block,
        slots: slots as u32,
        topo: offsets,
        filter: filter.as_ref(),
        semi_cg,
        cg_tolerance,
        cg_max_iterations,
        fixup_iterations: fixup_iterations(params),
        self_collision: self_collision.as_ref(),
        grids: grid_at,
    };
    let params = uniform_block(model, params, shape);
    // Self-collision's rest positions, then their seam partners' (see
    // `sc_rest` and `sc_seam_rest`).
    let rest = match &self_collision {
        Some(c) => {
            let mut rest = try_with_capacity(2 * c.rest.len(), UPLOAD)?;
            rest.extend(
                c.rest
                    .iter()
                    .chain(&c.seam_rest)
                    .map(|r| [r.x, r.y, r.z, 0.0]),
            );
            rest
        }
        None => Vec::new(),
    };
    Ok(ClothArrays {
        params,
        springs,
        topo,
        x,
        v,
        dense: filter.map_or_else(Vec::new, |f| f.words),
        rest,
        grids,
        bending: bending_words(model)?,
    })
}

impl GpuSolver {
    /// Allocates the buffers and takes the step plan's pipelines from
    /// `kernels` (the parameters and the limits were checked by
    /// [`GpuSolver::with_kernels`]).
    pub(super) fn build(
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
        filter: Option<SemiFilter>,
        grid: Option<GridLayout>,
        kernels: GpuKernels,
        path: PathChoice,
    ) -> Result<GpuSolver> {
        let device = &kernels.device().clone();
        let block = GridBlock::ONE;
        let semi_cg = filter.as_ref().is_some_and(|f| f.words.is_empty());
        let cg_max_iterations = if semi_cg {
            FILTER_CG_MAX_ITERATIONS
        } else {
            params.implicit.max_iterations
        };
        let mut arrays = cloth_arrays(model, params, filter, grid.as_ref(), block)?;
        arrays.place(0, 0);
        let slots = arrays.springs.len();
        let fixup_iterations = fixup_iterations(params);
        let buffers = ClothBuffers::new(
            device,
            queue,
            &kernels,
            &Uploads {
                params: &arrays.params,
                model: &arrays.model_words()?,
                model_len: arrays.model_len(),
                springs: &arrays.springs,
                work_len: arrays.work_len(),
                status_len: arrays.status_len(),
                x: &arrays.x,
                v: &arrays.v,
                triangles: &model.triangles,
                constant_blocks: semi_cg.then_some((params.dt * params.dt) as f32),
                cg_max_iterations,
                workgroup: path.path == StepPath::Workgroup,
            },
        )?;
        let gpu_params = arrays.params;
        let features = compiled_features(
            scene_features(model, params, grid.as_ref().map(|_| block)),
            path.path,
        );
        let inputs = plan_inputs(
            params.integrator,
            features,
            &gpu_params,
            slots as u32,
            fixup_iterations,
            path.path,
        );
        let prepared = Prepared::new(&kernels, &inputs)?;
        queue.submit([]);
        Ok(GpuSolver {
            device: device.clone(),
            queue: queue.clone(),
            integrator: params.integrator,
            spring_slots: slots as u32,
            grid: grid.is_some(),
            block,
            fixup_iterations,
            cg: CgBudget::new(cg_max_iterations),
            params: gpu_params,
            buffers,
            kernels,
            prepared,
            features,
            steps_recorded: 0,
            dt: params.dt,
            model: model.try_clone()?,
            recorded: std::cell::Cell::new((0, 0)),
            specialised: true,
            host_params: params.clone(),
            path,
            rewind: None,
            motion: Motion::new(model, params),
        })
    }
}
