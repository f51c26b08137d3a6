//! Building a [`GpuSolver`]: the buffers, the one bind group and the
//! pipelines of the scene's variant.

use wgpu::util::DeviceExt;

use super::grid::{fixup_limit, GridBlock, GridLayout};
use super::kernel::ArgsGroup;
use super::kernels::GpuKernels;
use super::layout::{self, section, GpuParams, GpuSpring};
use super::semi_filter::{SemiFilter, FILTER_CG_MAX_ITERATIONS, FILTER_CG_TOLERANCE};
use super::solver::{
    gpu_spheres, plan_inputs, scene_features, GpuSolver, Prepared, NO_GROUND, NO_WIND,
};
use crate::aggregation::Aggregation;
use crate::budget::{try_collect, try_vec, try_with_capacity};
use crate::error::Result;
use crate::kernel_config::WORKGROUP;
use crate::model::Model;
use crate::params::Params;

/// What the arrays built for upload are named in a memory error.
const UPLOAD: &str = "the GPU solver's buffers (their host copies)";

impl GpuSolver {
    /// Allocates the buffers, the bind group and the pipelines (the limits
    /// were checked by [`GpuSolver::new`]).
    pub(super) fn build(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
        params: &Params,
        filter: Option<SemiFilter>,
        grid: Option<GridLayout>,
        kernels: GpuKernels,
    ) -> Result<GpuSolver> {
        let n = model.particle_count() as u32;
        let partial_count = n.div_ceil(WORKGROUP);
        let block = GridBlock::for_adapter(&device.adapter_info());
        let semi_cg = filter.as_ref().is_some_and(|f| f.words.is_empty());
        let (cg_tolerance, cg_max_iterations) = if semi_cg {
            (FILTER_CG_TOLERANCE, FILTER_CG_MAX_ITERATIONS)
        } else {
            (params.implicit.tolerance, params.implicit.max_iterations)
        };

        // Where each spring lives on the device: its slot in grid layout,
        // else its index.
        let slot_of = |s: usize| grid.as_ref().map_or(s as u32, |g| g.slot[s]);
        let slots = grid.as_ref().map_or(model.springs.len(), GridLayout::slots);

        // Topology: spring CSR (offsets, entries — with slots for spring
        // indices — then each entry's other particle), triangle CSR,
        // triangles, one u32 array.
        let words = 2 * model.particle_springs.entries.len()
            + model.particle_springs.offsets.len()
            + model.particle_triangles.offsets.len()
            + model.particle_triangles.entries.len()
            + 3 * model.triangles.len();
        let mut topo: Vec<u32> = try_with_capacity(words, UPLOAD)?;
        topo.extend(&model.particle_springs.offsets);
        let spring_adj_entries = topo.len() as u32;
        topo.extend(
            model
                .particle_springs
                .entries
                .iter()
                .map(|&e| slot_of((e >> 1) as usize) << 1 | (e & 1)),
        );
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

        // Unused grid slots: a spring of zero stiffness from the owner to
        // itself (no kernel reaches them; see `super::grid`).
        let owner = |slot: usize| (slot % model.particle_count().max(1)) as u32;
        let mut gpu_springs: Vec<GpuSpring> = try_collect(
            (0..slots).map(|slot| GpuSpring {
                i: owner(slot),
                j: owner(slot),
                ..GpuSpring::default()
            }),
            UPLOAD,
        )?;
        let placed = model.springs.iter().map(|sp| {
            let m = params.spring(sp.kind);
            let max_len = fixup_limit(sp, params);
            GpuSpring {
                i: sp.i,
                j: sp.j,
                rest: sp.rest as f32,
                k: m.stiffness as f32,
                kd: m.damping as f32,
                max_len,
                _pad: [0; 2],
            }
        });
        for (s, spring) in placed.enumerate() {
            gpu_springs[slot_of(s) as usize] = spring;
        }
        let kind = |f: fn(&crate::params::SpringParams) -> f64| {
            let k = params.springs.map(|m| f(&m) as f32);
            // The fourth stays 0: kind_k's is the kernels' opaque zero.
            [k[0], k[1], k[2], 0.0]
        };
        let (grid_words, rest, max_len) = match &grid {
            Some(g) => (
                [g.nx, g.ny, g.kinds, block.count(g.nx, g.ny)],
                g.rest,
                g.max_len,
            ),
            None => ([0; 4], [0.0; 6], [0.0; 6]),
        };

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
            spring_count: slots as u32,
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
            grid: grid_words,
            grid_rest_a: [rest[0], rest[1], rest[2], rest[3]],
            grid_rest_b: [rest[4], rest[5], 0.0, 0.0],
            grid_max_a: [max_len[0], max_len[1], max_len[2], max_len[3]],
            grid_max_b: [max_len[4], max_len[5], 0.0, 0.0],
            kind_k: kind(|m| m.stiffness),
            kind_kd: kind(|m| m.damping),
            kind_a: if semi_cg {
                let dt2 = (params.dt * params.dt) as f32;
                kind(|m| m.stiffness).map(|k| dt2 * k)
            } else {
                [0.0; 4]
            },
            coarse: Aggregation::for_scene(model, params).map_or([0; 4], |a| {
                [a.nx, a.ny, a.count(0), a.count(1)].map(|c| c as u32)
            }),
            spheres,
        };

        let x0: Vec<[f32; 4]> = try_collect(
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
        let v0: Vec<[f32; 4]> = try_collect(
            model.mass.iter().map(|&m| [0.0, 0.0, 0.0, m as f32]),
            UPLOAD,
        )?;

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
            wgpu::BufferUsages::UNIFORM
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
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
        let mut blocks = try_vec(
            layout::SPRING_SECTIONS as usize * gpu_springs.len(),
            [0f32; 4],
            UPLOAD,
        )?;
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
            layout: kernels.group0(),
            entries: &bind_entries,
        });
        // The per-particle CG kernels are dispatched indirectly from
        // `cg_args`, which the CG scalar kernels zero when CG stops: a
        // stopped iteration then runs no workgroup. It lives in its own
        // group, bound only to the kernels that write it (a dispatch may
        // not read its arguments from a buffer its kernel binds).
        // cg_start writes the workgroup counts at the start of every
        // solve, before any dispatch reads them (set_cg_args in
        // shaders/common/cg.wgsl is their one formula).
        let cg_args = init(
            "wgcloth.cg_args",
            bytemuck::cast_slice(&[0u32, 1, 1, 0, 1, 1]),
            storage | wgpu::BufferUsages::INDIRECT,
        );
        // The scalar kernels' own indirect arguments: a (workgroups, 1, 1)
        // slot per CG iteration, which the kernels enable one ahead and
        // clear behind them (see alpha_slots in shaders/common/cg.wgsl).
        let slot_words: Vec<u32> = (0..cg_max_iterations.max(1))
            .flat_map(|_| [0u32, 1, 1])
            .collect();
        let slot_buffer = |label: &str| {
            init(
                label,
                bytemuck::cast_slice(&slot_words),
                storage | wgpu::BufferUsages::INDIRECT,
            )
        };
        let alpha_slots = slot_buffer("wgcloth.alpha_slots");
        let beta_slots = slot_buffer("wgcloth.beta_slots");
        // Group 1 of each kernel that writes dispatch arguments: cg_args
        // and the slots of the other scalar kernel (cg_start: both).
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

        let features = scene_features(model, params, grid.as_ref().map(|_| block));
        let fixup_iterations = if params.springs.iter().any(|s| s.max_stretch.is_some()) {
            params.fixup.iterations
        } else {
            0
        };
        let prepared = Prepared::new(
            &kernels,
            &plan_inputs(
                params.integrator,
                features,
                &gpu_params,
                slots as u32,
                fixup_iterations,
            ),
        )?;
        queue.submit([]);

        Ok(GpuSolver {
            device: device.clone(),
            queue: queue.clone(),
            integrator: params.integrator,
            particles: n,
            springs: model.springs.len() as u32,
            spring_slots: slots as u32,
            grid: grid.is_some(),
            block,
            triangles: model.triangles.len() as u32,
            fixup_iterations,
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
            springs_buffer,
            topo: topo_buffer,
            work,
            spring_work,
            partials,
            bind_group,
            cg_args,
            alpha_slots,
            beta_slots,
            args_groups,
            kernels,
            prepared,
            features,
            steps_recorded: 0,
            dt: params.dt,
            model: model.try_clone()?,
            recorded: std::cell::Cell::new((0, 0)),
            specialised: true,
            host_params: params.clone(),
            dense,
        })
    }
}
