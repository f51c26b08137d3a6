//! Shared by `tests/kernel_twins.rs`: a GPU solver and its `f32` CPU
//! mirror side by side, the device's buffers as CPU values, and
//! comparison of output words under the agreement policy
//! (`gpu_common::agreement`): bit for bit where the adapter rounds like
//! the mirror, within [`agreement::KERNEL`] elsewhere.

use wgcloth::cpu::twins::{self, CpuSolver, Filter, SpringBlock, State, Sym3, System, Workspace};
use wgcloth::gpu::{DebugBuffer, Dispatch, GpuSolver, Kernel, StepPath};
use wgcloth::kernel_config::filter_kind::{FIXED, FREE, HELD, PLANE};
use wgcloth::real::Vec3;
use wgcloth::{Model, Params};

use crate::gpu_common::agreement::{self, Policy};
use crate::gpu_common::gpu;

/// A GPU solver and the `f32` CPU mirror of the same cloth, in the same
/// state.
pub struct Twins {
    /// The device's solver.
    pub gpu: GpuSolver,
    /// The CPU mirror.
    pub cpu: CpuSolver<f32>,
    /// Particles.
    pub n: usize,
    /// Springs.
    pub s: usize,
    /// The GPU runs the grid kernels (a grid cloth, specialised kernels).
    pub grid: bool,
}

impl Twins {
    /// Both solvers for `model` under `params`, the GPU's with its general
    /// kernels unless `specialised`, stepped `warm` steps; panics unless
    /// they then agree bit for bit (under the bounded policy: unless each
    /// step, the mirror re-seeded before it, lies within its bound). The
    /// GPU records every CG iteration (no adaptive budget), as the CPU
    /// runs them.
    pub fn new(model: &Model, params: &Params, specialised: bool, warm: u32) -> Self {
        let t = Self::unchecked(model, params, specialised, warm);
        t.assert_states_agree("after the warm-up");
        t
    }

    /// Panics unless the device's positions and velocities (with the
    /// masses in w) equal the mirror's bit for bit; `when` names the
    /// moment in the message. Under the bounded policy the steps that
    /// led here were each compared as they ran (see [`Twins::on_path`]),
    /// and this checks nothing more.
    pub fn assert_states_agree(&self, when: &str) {
        if agreement::policy() == Policy::Bounded {
            return;
        }
        let x = self.read(DebugBuffer::X);
        let v = self.read(DebugBuffer::V);
        let st = self.cpu.state();
        assert_exact(
            &format!("x {when}"),
            &x,
            &pack(&st.x, |p| inv_mass(&self.cpu, p)),
        );
        assert_exact(
            &format!("v {when}"),
            &v,
            &pack(&st.v, |p| mass(&self.cpu, p)),
        );
    }

    /// As [`Twins::new`], for a scene whose backends are not expected to
    /// agree bit for bit after the warm-up (the semi-implicit filter
    /// solved by CG on the device, exactly on the CPU): the tests load
    /// every input from the device anyway.
    pub fn unchecked(model: &Model, params: &Params, specialised: bool, warm: u32) -> Self {
        Self::build(
            model,
            params,
            specialised,
            warm,
            StepPath::MultiDispatch,
            false,
        )
    }

    /// As [`Twins::unchecked`], the GPU stepping on `path`.
    pub fn on_path(
        model: &Model,
        params: &Params,
        specialised: bool,
        warm: u32,
        path: StepPath,
    ) -> Self {
        Self::build(model, params, specialised, warm, path, false)
    }

    /// The twins after `warm` steps; under the bounded policy the mirror
    /// is re-seeded before each, and each is compared if `check`.
    fn build(
        model: &Model,
        params: &Params,
        specialised: bool,
        warm: u32,
        path: StepPath,
        check: bool,
    ) -> Self {
        let ctx = gpu();
        let mut g = GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, model, params, path)
            .unwrap_or_else(|e| panic!("GPU solver on the {path} path: {e}"));
        let mut tuning = g.tuning_mut();
        tuning
            .set_specialised(specialised)
            .unwrap_or_else(|e| panic!("kernels: {e}"));
        tuning.set_adaptive_cg_budget(false);
        let mut c = CpuSolver::<f32>::new(model, params).unwrap_or_else(|e| panic!("CPU: {e}"));
        match agreement::policy() {
            Policy::Bits if warm > 0 => {
                g.step(warm).unwrap_or_else(|e| panic!("GPU steps: {e}"));
                c.step_n(u64::from(warm))
                    .unwrap_or_else(|e| panic!("CPU steps: {e}"));
            }
            Policy::Bits => {}
            Policy::Bounded => {
                let bound = agreement::step_bound(params);
                for step in 0..warm {
                    let before = agreement::before_step(&g, &mut c);
                    g.step(1).unwrap_or_else(|e| panic!("GPU step: {e}"));
                    c.step().unwrap_or_else(|e| panic!("CPU step: {e}"));
                    if check {
                        let after = agreement::Stepper::state(&g);
                        let what = format!("warm-up step {step} on the {path} path");
                        agreement::check_after_step(&what, &before, &after, &c, &bound)
                            .unwrap_or_else(|e| panic!("{e}"));
                    }
                }
            }
        }
        Twins {
            n: model.particle_count(),
            s: model.springs.len(),
            grid: specialised && model.grid.is_some(),
            gpu: g,
            cpu: c,
        }
    }

    /// Loads the device's positions and velocities into the mirror's
    /// state.
    pub fn load_state(&mut self) {
        let n = self.n;
        let x = xyz(&self.read(DebugBuffer::X), 0, n);
        let v = xyz(&self.read(DebugBuffer::V), 0, n);
        self.cpu
            .set_state(State { x, v })
            .unwrap_or_else(|e| panic!("state: {e}"));
    }

    /// The device's section `sec` of the per-particle scratch as vectors.
    pub fn work_xyz(&self, sec: usize) -> Vec<Vec3<f32>> {
        xyz(&self.read(DebugBuffer::Work), sec, self.n)
    }

    /// The mirror's inverse masses and masses (the w of `x` and `v`).
    pub fn masses(&self) -> (Vec<f32>, Vec<f32>) {
        let sys = self.cpu.system();
        (sys.inv_mass.clone(), sys.mass.clone())
    }

    /// The next step's dispatches.
    pub fn plan(&self) -> Vec<Dispatch> {
        self.gpu.debug_plan()
    }

    /// Runs the next step's dispatches before the `nth` (from 0) of
    /// `kernel` and returns its index in the plan; panics if the plan has
    /// no such dispatch.
    pub fn run_to(&mut self, kernel: Kernel, nth: usize) -> usize {
        let plan = self.plan();
        let at = plan
            .iter()
            .enumerate()
            .filter(|(_, d)| d.kernel == kernel)
            .nth(nth)
            .map(|(i, _)| i)
            .unwrap_or_else(|| panic!("no dispatch {nth} of {} in {plan:?}", kernel.name()));
        self.gpu
            .debug_run(0..at)
            .unwrap_or_else(|e| panic!("GPU plan up to {}: {e}", kernel.name()));
        at
    }

    /// Runs dispatch `at` of the plan alone.
    pub fn run_alone(&mut self, at: usize) {
        self.gpu
            .debug_run(at..at + 1)
            .unwrap_or_else(|e| panic!("GPU dispatch {at}: {e}"));
    }

    /// The device's buffer `b`, as words.
    pub fn read(&self, b: DebugBuffer) -> Vec<u32> {
        self.gpu
            .debug_read(b)
            .unwrap_or_else(|e| panic!("reading {b:?}: {e}"))
    }

    /// The mirror's system, state and workspace.
    pub fn parts(&mut self) -> (&System<f32>, &mut State<f32>, &mut Workspace<f32>) {
        twins::parts(&mut self.cpu)
    }
}

/// Particle `p`'s inverse mass in the mirror (the w of the GPU's `x`).
pub fn inv_mass(c: &CpuSolver<f32>, p: usize) -> f32 {
    c.system().inv_mass[p]
}

/// Particle `p`'s mass in the mirror (the w of the GPU's `v`).
pub fn mass(c: &CpuSolver<f32>, p: usize) -> f32 {
    c.system().mass[p]
}

/// Entry `i`'s four words of section `sec` (entries of `len` each) of a
/// sectioned buffer of `vec4`s.
fn entry(words: &[u32], sec: usize, len: usize, i: usize) -> [u32; 4] {
    let at = (sec * len + i) * 4;
    [words[at], words[at + 1], words[at + 2], words[at + 3]]
}

/// Section `sec`'s words (entries of `len` `vec4`s each).
pub fn section(words: &[u32], sec: usize, len: usize) -> &[u32] {
    &words[sec * len * 4..(sec + 1) * len * 4]
}

/// The xyz of section `sec`'s `len` entries.
pub fn xyz(words: &[u32], sec: usize, len: usize) -> Vec<Vec3<f32>> {
    (0..len)
        .map(|i| {
            let e = entry(words, sec, len, i).map(f32::from_bits);
            Vec3::new(e[0], e[1], e[2])
        })
        .collect()
}

/// The w of section `sec`'s `len` entries.
pub fn w(words: &[u32], sec: usize, len: usize) -> Vec<f32> {
    (0..len)
        .map(|i| f32::from_bits(entry(words, sec, len, i)[3]))
        .collect()
}

/// `vec4` words of `v` with `w(i)` as the fourth component.
pub fn pack(v: &[Vec3<f32>], w: impl Fn(usize) -> f32) -> Vec<u32> {
    v.iter()
        .enumerate()
        .flat_map(|(i, a)| [a.x, a.y, a.z, w(i)].map(f32::to_bits))
        .collect()
}

/// `vec4` words of `v` with w 0, as the kernels store a vector.
pub fn vectors(v: &[Vec3<f32>]) -> Vec<u32> {
    pack(v, |_| 0.0)
}

/// Words of `f32` values.
pub fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|f| f.to_bits()).collect()
}

/// Panics unless the device's `f32` words agree with the twin's under the
/// policy (bit for bit, or within [`agreement::KERNEL`]), naming the word
/// (`vec4` entry and component) and both values.
pub fn assert_same(what: &str, gpu: &[u32], cpu: &[u32]) {
    agreement::check_words(what, gpu, cpu, &agreement::KERNEL).unwrap_or_else(|e| panic!("{e}"));
}

/// Panics unless the device's words equal the twin's bit for bit on every
/// adapter: integers (cells, counts, indices) and flags, which no
/// rounding may change once the inputs are the same words.
pub fn assert_exact(what: &str, gpu: &[u32], cpu: &[u32]) {
    agreement::check_bits(what, gpu, cpu).unwrap_or_else(|e| panic!("{e}"));
}

/// The filter kind the GPU stores for `f`.
pub fn kind(f: &Filter<f32>) -> f32 {
    match f {
        Filter::Free => FREE,
        Filter::Fixed => FIXED,
        Filter::Plane(..) => PLANE,
        Filter::Held(..) => HELD,
    }
}

/// The filters the device holds: kind from the w of section `z`, a
/// contact's normal and friction from section `filter`.
pub fn filters(work: &[u32], z: usize, filter: usize, n: usize) -> Vec<Filter<f32>> {
    let kinds = w(work, z, n);
    let normals = xyz(work, filter, n);
    let friction = w(work, filter, n);
    (0..n)
        .map(|p| match kinds[p] {
            k if k == FIXED => Filter::Fixed,
            k if k == PLANE => Filter::Plane(normals[p], friction[p]),
            k if k == HELD => Filter::Held(normals[p], friction[p]),
            _ => Filter::Free,
        })
        .collect()
}

/// The symmetric matrices whose diagonal is in section `diag` and
/// off-diagonal (xy, xz, yz) in `off`.
pub fn sym3s(work: &[u32], diag: usize, off: usize, len: usize) -> Vec<Sym3<f32>> {
    let d = xyz(work, diag, len);
    let o = xyz(work, off, len);
    (0..len)
        .map(|i| Sym3 {
            m: [d[i].x, d[i].y, d[i].z, o[i].x, o[i].y, o[i].z],
        })
        .collect()
}

/// The diagonals and off-diagonals of `m` as two sections' words.
pub fn pack_sym3s(m: &[Sym3<f32>]) -> (Vec<u32>, Vec<u32>) {
    let d: Vec<Vec3<f32>> = m
        .iter()
        .map(|s| Vec3::new(s.m[0], s.m[1], s.m[2]))
        .collect();
    let o: Vec<Vec3<f32>> = m
        .iter()
        .map(|s| Vec3::new(s.m[3], s.m[4], s.m[5]))
        .collect();
    (pack(&d, |_| 0.0), pack(&o, |_| 0.0))
}

/// The spring blocks (m xyz, a w) of section `sec` of the device's
/// per-spring scratch, with their ends from the mirror's springs.
pub fn blocks(spring_work: &[u32], sec: usize, sys: &System<f32>) -> Vec<SpringBlock<f32>> {
    let s = sys.springs.len();
    let m = xyz(spring_work, sec, s);
    let a = w(spring_work, sec, s);
    (0..s)
        .map(|k| SpringBlock {
            m: m[k],
            a: a[k],
            ends: [sys.springs[k].i, sys.springs[k].j],
        })
        .collect()
}
