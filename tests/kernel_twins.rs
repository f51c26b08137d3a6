//! Each GPU kernel alone against its CPU twin (`wgcloth::cpu::twins`).
//!
//! A test builds a small cloth on both backends and steps both a few
//! times (they agree bit for bit), runs the GPU's plan for the next step up
//! to the kernel's dispatch, reads the kernel's inputs back from the device
//! and loads them into the twin's, then runs the dispatch alone and the
//! twin alone and compares every output word bit for bit. Inputs taken
//! from the device make each a test of that kernel, not of the step so
//! far. Where the GPU keeps something else in a `w` (a term of a CG dot
//! product, a filter kind, a mass), the twin keeps it in an array of its
//! own and the test compares it from there.
//!
//! The general (adjacency) kernels run on a grid's parts rebuilt with
//! `Model::from_parts`, whose springs the device keeps in the model's
//! order; the coarse levels and the single-pass explicit step need a grid.

mod gpu_common;
use gpu_common::agreement::{self, Policy};
#[path = "gpu_common/twins.rs"]
mod twins;

use gpu_common::agreement::{check_bits, check_values, Bound};
use gpu_common::layers::embedded;
use gpu_common::{busy_params, corners, folded_model, folded_positions, grid, without_grid};
use twins::{
    assert_exact, assert_same, bits, blocks, filters, kind, pack, pack_sym3s, section, sym3s,
    vectors, w, xyz, Twins,
};
use wgcloth::cpu::skin;
use wgcloth::cpu::twins as cpu;
use wgcloth::cpu::twins::Filter;
use wgcloth::gpu::{readback, GpuRenderMesh, SkinLayout};
use wgcloth::gpu::{DebugBuffer, Dispatch, Kernel, StepPath, Variant};
use wgcloth::kernel_config::filter_kind::HELD_NEXT;
use wgcloth::kernel_config::{partials, spring_work, status, work, CG_BLOCK};
use wgcloth::params::{FilterMethod, Integrator, Integrator::*};
use wgcloth::real::Vec3;
use wgcloth::Params;

/// Columns and rows of the test cloths: 529 particles, three of CG's
/// reduction blocks of 256 (and nine of the torque's 64), so the sums
/// cross block boundaries and end in a partial block.
const NX: usize = 23;
const NY: usize = 23;

/// Columns and rows of the coarse levels' test cloth, a long strip: 18 × 1
/// level-2 aggregates of 16 slots, 288 slots, so the per-slot update's
/// partial sums span two workgroups, the last partial; every level-2
/// aggregate is cut short by the last row, the last one by the last
/// column too.
const COARSE_NX: usize = 282;
const COARSE_NY: usize = 5;

/// Steps both solvers take before a kernel is compared: enough for the
/// busy scene's cloth to sag, swing in the wind and, implicitly, start
/// reaching the sphere (so CG's filters include planes).
const WARM_STEPS: u32 = 24;

/// Busy parameters (wind, ground, sphere, Jacobi fix-up) for
/// `integrator`, stretch springs limited to their rest length so that the
/// fix-up moves particles every pass.
fn params(integrator: Integrator) -> Params {
    let mut p = busy_params(integrator);
    p.springs[0].max_stretch = Some(1.0);
    p
}

/// The busy scene for `integrator` on the general kernels: pinned at
/// two corners, or free (`pinned = false`, which runs the semi-implicit
/// torque passes).
fn general(integrator: Integrator, pinned: bool) -> Twins {
    let p = params(integrator);
    let pins = if pinned { corners() } else { Vec::new() };
    let model = without_grid(&grid(NX, NY, pins, &p));
    Twins::new(&model, &p, false, WARM_STEPS)
}

/// The busy implicit scene on a grid with coarse levels, its GPU on the
/// general kernels (which keep the coarse levels, `cg_apply` adding level
/// 2's correction to each `s` it loads) or the grid's own
/// (`specialised`).
fn coarse(specialised: bool) -> Twins {
    let mut p = params(Integrator::Implicit);
    p.implicit.coarse_levels = true;
    let model = grid(COARSE_NX, COARSE_NY, corners(), &p);
    Twins::new(&model, &p, specialised, WARM_STEPS)
}

/// The busy scene for `integrator` on the general kernels (see
/// [`general`]), run up to the `nth` dispatch of `kernel`, and its index.
fn general_at(integrator: Integrator, pinned: bool, kernel: Kernel, nth: usize) -> (Twins, usize) {
    let mut t = general(integrator, pinned);
    let i = t.run_to(kernel, nth);
    (t, i)
}

/// Runs `check` at the `nth` dispatch of `kernel` in the busy scene for
/// `integrator` on the general kernels, then in `other`.
fn in_general_and(
    integrator: Integrator,
    other: fn() -> Twins,
    kernel: Kernel,
    nth: usize,
    check: fn(&mut Twins, usize),
) {
    let (mut t, i) = general_at(integrator, true, kernel, nth);
    check(&mut t, i);
    let mut t = other();
    let i = t.run_to(kernel, nth);
    check(&mut t, i);
}

/// The busy scene for `integrator` on the grid kernels, pinned at two
/// corners.
fn on_grid(integrator: Integrator) -> Twins {
    let p = params(integrator);
    let model = grid(NX, NY, corners(), &p);
    Twins::new(&model, &p, true, WARM_STEPS)
}

/// The busy explicit scene on the grid kernels (with fix-up: not single
/// pass).
fn explicit_grid() -> Twins {
    on_grid(Integrator::Explicit)
}

/// The busy semi-implicit scene on the grid kernels.
fn semi_grid() -> Twins {
    on_grid(Integrator::SemiImplicit)
}

/// A twin test, `$test`, that runs `$check` at the `$nth` dispatch of
/// `$kernel` in the busy scene for `$integrator` on the general kernels,
/// then in the scene `$other` makes.
macro_rules! general_and {
    ($test:ident: $integrator:ident, $other:ident, $kernel:ident, $nth:literal, $check:ident) => {
        #[test]
        fn $test() {
            in_general_and($integrator, $other, Kernel::$kernel, $nth, $check);
        }
    };
}

/// The busy implicit scene with coarse levels on the general kernels.
fn coarse_general() -> Twins {
    coarse(false)
}

/// The busy implicit scene with coarse levels on the grid kernels.
fn coarse_grid() -> Twins {
    coarse(true)
}

/// Every kernel with its twin test.
const TWIN_TESTS: &[(Kernel, fn())] = &[
    (Kernel::SpringForces, spring_forces_matches_its_twin),
    (
        Kernel::ExplicitIntegrate,
        explicit_integrate_matches_its_twin,
    ),
    (Kernel::ExplicitSeed, explicit_seed_matches_its_twin),
    (Kernel::FixupJacobi, fixup_jacobi_matches_its_twin),
    (Kernel::FinishStep, finish_step_matches_its_twin),
    (Kernel::Normals, normals_matches_its_twin),
    (Kernel::Skin, skin_matches_its_twin),
    (Kernel::ImplicitSprings, implicit_springs_matches_its_twin),
    (Kernel::ImplicitPrepare, implicit_prepare_matches_its_twin),
    (Kernel::CoarseSetup, coarse_setup_matches_its_twin),
    (Kernel::CgInit, cg_init_matches_its_twin),
    (Kernel::CgApply, cg_apply_matches_its_twin),
    (Kernel::CgUpdate, cg_update_matches_its_twin),
    (Kernel::ImplicitFinish, implicit_finish_matches_its_twin),
    (Kernel::SemiRhs, semi_rhs_matches_its_twin),
    (Kernel::FilterDense, filter_dense_matches_its_twin),
    (Kernel::TorqueCentre, torque_centre_matches_its_twin),
    (Kernel::TorqueMoments, torque_moments_matches_its_twin),
    (Kernel::TorqueApply, torque_apply_matches_its_twin),
    (Kernel::SemiIntegrate, semi_integrate_matches_its_twin),
    (Kernel::SemiCgPrepare, semi_cg_prepare_matches_its_twin),
    (Kernel::ClothExplicit, cloth_explicit_matches_its_twin),
    (Kernel::ClothImplicit, cloth_implicit_matches_its_twin),
    (
        Kernel::ClothSemiImplicit,
        cloth_semi_implicit_matches_its_twin,
    ),
    (
        Kernel::SelfCollisionCount,
        self_collision_count_matches_its_twin,
    ),
    (
        Kernel::SelfCollisionScan,
        self_collision_scan_matches_its_twin,
    ),
    (
        Kernel::SelfCollisionScatter,
        self_collision_scatter_matches_its_twin,
    ),
    (
        Kernel::SelfCollisionRank,
        self_collision_rank_matches_its_twin,
    ),
    (
        Kernel::SelfCollisionRespond,
        self_collision_respond_matches_its_twin,
    ),
];

/// Kernels without a twin, and why (see [`TWIN_TESTS`]).
const EXEMPT: &[(Kernel, &str)] = &[];

/// The share of kernel files that must have a twin test (issue #16).
const MIN_COVERAGE: f64 = 0.85;

#[test]
fn every_kernel_has_a_twin_test() {
    for k in Kernel::ALL {
        let tested = TWIN_TESTS.iter().filter(|(t, _)| *t == k).count();
        let exempt = EXEMPT.iter().any(|(e, _)| *e == k);
        assert!(
            tested == 1 && !exempt || tested == 0 && exempt,
            "{}: {tested} twin tests, exempt: {exempt}",
            k.name()
        );
    }
    let files = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders"))
        .expect("shaders/ is readable")
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "wgsl"))
        .count();
    assert_eq!(files, Kernel::ALL.len(), "one kernel per shaders/*.wgsl");
    let coverage = TWIN_TESTS.len() as f64 / files as f64;
    assert!(
        coverage >= MIN_COVERAGE,
        "{} of {files} kernel files have a twin test",
        TWIN_TESTS.len()
    );
}

/// A section index as a slice index.
fn at(section: u32) -> usize {
    section as usize
}

/// The device's per-spring scratch section `k` as vectors.
fn springs_xyz(t: &Twins, k: u32) -> Vec<Vec3<f32>> {
    xyz(&t.read(DebugBuffer::SpringWork), at(k), t.s)
}

/// The device's filters (kind in `W_Z`'s w, plane in `W_FILTER`).
fn device_filters(t: &Twins) -> Vec<Filter<f32>> {
    filters(
        &t.read(DebugBuffer::Work),
        at(work::Z),
        at(work::FILTER),
        t.n,
    )
}

/// The contacts the device holds by static friction in the next step
/// (`W_DV_PREV`'s w).
fn device_held(t: &Twins) -> Vec<bool> {
    w(&t.read(DebugBuffer::Work), at(work::DV_PREV), t.n)
        .iter()
        .map(|&w| w == HELD_NEXT)
        .collect()
}

/// The friction impulses the device's sliding contacts take in the next
/// step (`W_CLOCK`'s yzw).
fn device_friction(t: &Twins) -> Vec<Vec3<f32>> {
    let words = t.read(DebugBuffer::Work);
    section(&words, at(work::CLOCK), t.n)
        .chunks_exact(4)
        .map(|e| {
            let [y, z, w] = [e[1], e[2], e[3]].map(f32::from_bits);
            Vec3::new(y, z, w)
        })
        .collect()
}

/// The device's preconditioner (`W_PRE_DIAG`, `W_PRE_OFF`).
fn device_precond(t: &Twins) -> Vec<cpu::Sym3<f32>> {
    sym3s(
        &t.read(DebugBuffer::Work),
        at(work::PRE_DIAG),
        at(work::PRE_OFF),
        t.n,
    )
}

/// `W_FILTER`'s words for `filter`: a contact's normal and friction, else 0.
fn filter_words(filter: &[Filter<f32>]) -> Vec<u32> {
    let planes: Vec<(Vec3<f32>, f32)> = filter
        .iter()
        .map(|f| match f {
            Filter::Plane(n, mu) | Filter::Held(n, mu) => (*n, *mu),
            _ => (Vec3::ZERO, 0.0),
        })
        .collect();
    let normals: Vec<Vec3<f32>> = planes.iter().map(|p| p.0).collect();
    pack(&normals, |p| planes[p].1)
}

/// Section `k` of the device's per-particle scratch `words`.
fn work_section(t: &Twins, words: &[u32], k: u32) -> Vec<u32> {
    section(words, at(k), t.n).to_vec()
}

/// The block sums of `terms` in the CPU's reduction order, as words.
fn block_words(terms: &[f32]) -> Vec<u32> {
    let mut out = Vec::new();
    cpu::cg::block_partials(terms.len(), |p| terms[p], |_, sum| out.push(sum.to_bits()));
    out
}

/// The vectors `xyz` of `len` entries of section `k` of the device's
/// scratch, with the filter kinds in w as the device keeps them.
fn with_kinds(v: &[Vec3<f32>], filter: &[Filter<f32>]) -> Vec<u32> {
    pack(v, |p| kind(&filter[p]))
}

/// Loads the device's CG set-up into the mirror: spring blocks (see
/// `load_springs`), filters, preconditioner, right-hand side.
fn load_cg_setup(t: &mut Twins, grid: bool) {
    t.load_state();
    load_springs(t, grid);
    let work_words = t.read(DebugBuffer::Work);
    let filter = device_filters(t);
    let precond = device_precond(t);
    let n = t.n;
    let (_, _, wk) = t.parts();
    wk.filter = filter;
    wk.precond = precond;
    wk.rhs = xyz(&work_words, at(work::RHS), n);
    wk.delta0_terms = w(&work_words, at(work::RHS), n);
}

/// The sections a `fixup_jacobi` dispatch reads and writes.
fn fixup_sections(d: &Dispatch) -> (u32, u32) {
    match d.variant {
        Variant::Fixup(phase) if phase.index() % 2 == 1 => (work::X_ALT, work::X_PRED),
        Variant::Fixup(_) | Variant::FixupFirst => (work::X_PRED, work::X_ALT),
        other => panic!("fixup_jacobi as {other:?}"),
    }
}

/// Loads the device's state into the mirror, runs dispatch `i` alone and
/// returns the buffer `out` it writes.
fn run_on_state(t: &mut Twins, i: usize, out: DebugBuffer) -> Vec<u32> {
    t.load_state();
    t.run_alone(i);
    t.read(out)
}

#[test]
fn spring_forces_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::Explicit, true, Kernel::SpringForces, 0);
    let (out, s) = (run_on_state(&mut t, i, DebugBuffer::SpringWork), t.s);
    let (sys, st, wk) = t.parts();
    cpu::forces::spring_forces(sys, &st.x, &st.v, &mut wk.per_spring);
    assert_same(
        "S_FORCE",
        section(&out, at(spring_work::FORCE), s),
        &vectors(&wk.per_spring),
    );
}

/// Loads the spring forces into the mirror: the device's spring pass's,
/// or on a grid, whose kernels compute each force where they sum it, the
/// spring pass's twin's on the mirror's state.
fn load_forces(t: &mut Twins) {
    let forces = (!t.grid).then(|| springs_xyz(t, spring_work::FORCE));
    let (sys, st, wk) = t.parts();
    match forces {
        Some(f) => wk.per_spring = f,
        None => cpu::forces::spring_forces(sys, &st.x, &st.v, &mut wk.per_spring),
    }
}

/// explicit_integrate's outputs against its twin's, in `t` at dispatch `i`
/// (on a grid: the twins of spring_forces and explicit_integrate).
fn check_explicit_integrate(t: &mut Twins, i: usize) {
    assert_eq!(t.plan()[i].variant, Variant::Plain);
    t.load_state();
    load_forces(t);
    check_prediction(t, i, |_| (), cpu::explicit::integrate);
}

general_and!(explicit_integrate_matches_its_twin: Explicit, explicit_grid, ExplicitIntegrate, 0, check_explicit_integrate);

/// Runs dispatch `i` alone and the integration twin `integrate` on the
/// mirror (its workspace given its inputs by `load`), and compares the
/// predicted positions and velocities (`W_X_PRED`, `W_V_NEW`).
fn check_prediction(
    t: &mut Twins,
    i: usize,
    load: impl FnOnce(&mut cpu::Workspace<f32>),
    integrate: fn(&cpu::System<f32>, &mut cpu::State<f32>, &mut cpu::Workspace<f32>),
) {
    t.run_alone(i);
    let out = t.read(DebugBuffer::Work);
    let (sys, st, wk) = t.parts();
    load(wk);
    integrate(sys, st, wk);
    let (x_pred, v_new) = (vectors(&st.x), vectors(&st.v));
    assert_same("W_X_PRED", &work_section(t, &out, work::X_PRED), &x_pred);
    assert_same("W_V_NEW", &work_section(t, &out, work::V_NEW), &v_new);
}

#[test]
fn explicit_seed_matches_its_twin() {
    // A grid without fix-up steps in one pass, seeded by explicit_seed.
    let mut p = params(Integrator::Explicit);
    p.fixup.iterations = 0;
    let model = grid(NX, NY, corners(), &p);
    let mut t = Twins::new(&model, &p, true, WARM_STEPS);
    let i = t.run_to(Kernel::ExplicitSeed, 0);
    t.load_state();
    let snapshot = [work::SNAPSHOT, work::SNAPSHOT + 1];
    let before = t.read(DebugBuffer::Work);
    t.run_alone(i);
    let out = t.read(DebugBuffer::Work);
    let (inv_mass, mass) = t.masses();
    let (_, st, _) = t.parts();
    let mut copy = cpu::State {
        x: Vec::new(),
        v: Vec::new(),
    };
    cpu::explicit::seed(st, &mut copy);
    let expected = [pack(&copy.x, |p| inv_mass[p]), pack(&copy.v, |p| mass[p])];
    for (k, want) in snapshot.into_iter().zip(expected) {
        let got = work_section(&t, &out, k);
        assert_ne!(
            got,
            work_section(&t, &before, k),
            "the snapshot held an older state"
        );
        assert_same(&format!("snapshot section {k}"), &got, &want);
    }
}

/// The first two fix-up passes' outputs against the twin's, in `t` from
/// dispatch `first`.
fn check_fixup_jacobi(t: &mut Twins, first: usize) {
    let plan = t.plan();
    // The first two passes: each reads one section and writes the other.
    for i in [first, first + 1] {
        assert_eq!(plan[i].kernel, Kernel::FixupJacobi);
        let (src, dst) = fixup_sections(&plan[i]);
        let mut x = t.work_xyz(at(src));
        t.run_alone(i);
        let out = t.read(DebugBuffer::Work);
        let flags = t.read(DebugBuffer::Status);
        let (sys, _, wk) = t.parts();
        let omega = sys.fixup_omega;
        let moved = cpu::fixup::jacobi(sys, &mut x, 1, omega, &mut wk.per_spring, &mut wk.active);
        assert_eq!(
            moved, 1,
            "pass {i}: the test scene's fix-up moves every pass"
        );
        let what = format!("pass at {i}: section {dst}");
        assert_same(&what, &work_section(t, &out, dst), &vectors(&x));
        assert_eq!(flags[status::FIXUP_MOVED], moved, "{what}: moved");
        assert_eq!(flags[status::FIXUP_RESULT], dst, "{what}: result");
        assert_eq!(
            flags[status::FIXUP_PASSES] as usize,
            i - first + 1,
            "{what}: passes"
        );
    }
}

general_and!(fixup_jacobi_matches_its_twin: Explicit, explicit_grid, FixupJacobi, 0, check_fixup_jacobi);

#[test]
fn finish_step_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::Explicit, true, Kernel::FinishStep, 0);
    t.load_state();
    let flags = t.read(DebugBuffer::Status);
    let result = t.work_xyz(at(flags[status::FIXUP_RESULT]));
    let v_new = t.work_xyz(at(work::V_NEW));
    let moved = flags[status::FIXUP_MOVED] != 0;
    assert!(moved, "the test scene's fix-up moves");
    t.run_alone(i);
    let (x, v) = (t.read(DebugBuffer::X), t.read(DebugBuffer::V));
    let (inv_mass, mass) = t.masses();
    let (sys, st, wk) = t.parts();
    wk.x_old.clone_from(&st.x);
    st.x = result;
    st.v = v_new;
    cpu::finish_step(sys, st, wk, moved);
    assert_same("x", &x, &pack(&st.x, |p| inv_mass[p]));
    assert_same("v", &v, &pack(&st.v, |p| mass[p]));
}

#[test]
fn implicit_springs_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::Implicit, true, Kernel::ImplicitSprings, 0);
    let (out, s) = (run_on_state(&mut t, i, DebugBuffer::SpringWork), t.s);
    let (sys, st, wk) = t.parts();
    cpu::implicit::springs(sys, st, wk);
    let m: Vec<Vec3<f32>> = wk.blocks.iter().map(|b| b.m).collect();
    let sec = |k: u32| section(&out, at(k), s);
    assert_same(
        "S_BLOCK",
        sec(spring_work::BLOCK),
        &pack(&m, |k| wk.blocks[k].a),
    );
    assert_same("S_KV", sec(spring_work::KV), &vectors(&wk.kv));
    assert_same("S_FORCE", sec(spring_work::FORCE), &vectors(&wk.per_spring));
}

/// Loads the spring pass's results into the mirror: from the device's
/// per-spring scratch (general kernels), or, on a grid, where the kernels
/// linearise each spring where they use it, from the twin of that pass on
/// the mirror's state.
fn load_springs(t: &mut Twins, grid: bool) {
    let spring_words = t.read(DebugBuffer::SpringWork);
    let (sys, st, wk) = t.parts();
    if grid {
        cpu::implicit::springs(sys, st, wk);
        return;
    }
    let s = sys.springs.len();
    wk.per_spring = xyz(&spring_words, at(spring_work::FORCE), s);
    wk.kv = xyz(&spring_words, at(spring_work::KV), s);
    wk.blocks = blocks(&spring_words, at(spring_work::BLOCK), sys);
}

/// The CG set-up a prepare kernel leaves in the device's scratch `out` and
/// status words `flags` (filters, preconditioner, warm-started Δv,
/// right-hand side with δ0's terms, CG's count and stop reset) against
/// the twin's in `wk`.
fn assert_cg_setup(out: &[u32], flags: &[u32], wk: &cpu::Workspace<f32>, n: usize) {
    let (diag, off) = pack_sym3s(&wk.precond);
    let sec = |k: u32| section(out, at(k), n).to_vec();
    assert_same("W_Z", &sec(work::Z), &with_kinds(&wk.z, &wk.filter));
    assert_same("W_FILTER", &sec(work::FILTER), &filter_words(&wk.filter));
    assert_same("W_PRE_DIAG", &sec(work::PRE_DIAG), &diag);
    assert_same("W_PRE_OFF", &sec(work::PRE_OFF), &off);
    assert_same("W_DV", &sec(work::DV), &with_kinds(&wk.dv, &wk.filter));
    let dv_prev = vectors(&wk.dv_prev);
    assert_same("W_DV_PREV", &sec(work::DV_PREV), &dv_prev);
    let terms = &wk.delta0_terms;
    assert_same("W_RHS", &sec(work::RHS), &pack(&wk.rhs, |p| terms[p]));
    assert_eq!(flags[status::CG_ITERATIONS], wk.cg.iterations);
    assert_eq!(flags[status::CG_STOPPED], u32::from(wk.cg.stopped));
}

/// implicit_prepare's outputs against its twin's, in `t` at dispatch `i`
/// (on a grid: the twins of implicit_springs and implicit_prepare).
fn check_implicit_prepare(t: &mut Twins, i: usize) {
    let grid = t.grid;
    t.load_state();
    load_springs(t, grid);
    let dv = t.work_xyz(at(work::DV));
    let dv_prev = t.work_xyz(at(work::DV_PREV));
    let held = device_held(t);
    let friction = device_friction(t);
    t.run_alone(i);
    let out = t.read(DebugBuffer::Work);
    let flags = t.read(DebugBuffer::Status);
    let n = t.n;
    let (inv_mass, _) = t.masses();
    let (sys, st, wk) = t.parts();
    wk.dv = dv;
    wk.dv_prev = dv_prev;
    wk.held = held;
    wk.friction = friction;
    cpu::implicit::prepare(sys, st, wk);
    let planes = wk
        .filter
        .iter()
        .filter(|f| matches!(f, Filter::Plane(..)))
        .count();
    assert!(planes > 0, "the test cloth rests on a collider somewhere");
    assert_cg_setup(&out, &flags, wk, n);
    let sec = |k: u32| section(&out, at(k), n).to_vec();
    if grid {
        // The start-of-step positions, for implicit_finish's contacts.
        assert_same(
            "W_X_START",
            &sec(work::X_START),
            &pack(&st.x, |p| inv_mass[p]),
        );
    }
    if let Some(coarse) = &wk.coarse {
        for (level, (d, o)) in [
            (work::LEVEL1_D, work::LEVEL1_O),
            (work::LEVEL2_D, work::LEVEL2_O),
        ]
        .into_iter()
        .enumerate()
        {
            let m: Vec<cpu::Sym3<f32>> = coarse.contrib.iter().map(|c| c[level]).collect();
            let (diag, off) = pack_sym3s(&m);
            assert_same(&format!("level {} D", level + 1), &sec(d), &diag);
            let trace = |p: usize| if level == 0 { coarse.trace[p] } else { 0.0 };
            let off: Vec<u32> = off
                .chunks(4)
                .enumerate()
                .flat_map(|(p, e)| [e[0], e[1], e[2], trace(p).to_bits()])
                .collect();
            assert_same(
                &format!("level {} D, off-diagonal", level + 1),
                &sec(o),
                &off,
            );
        }
    }
}

// On a grid the kernel linearises the springs itself.
general_and!(implicit_prepare_matches_its_twin: Implicit, coarse_grid, ImplicitPrepare, 0, check_implicit_prepare);

#[test]
fn coarse_setup_matches_its_twin() {
    let mut t = coarse(false);
    let i = t.run_to(Kernel::CoarseSetup, 0);
    let before = t.read(DebugBuffer::Work);
    t.run_alone(i);
    let out = t.read(DebugBuffer::Work);
    let n = t.n;
    let (sys, _, wk) = t.parts();
    let coarse = wk.coarse.as_mut().expect("coarse levels");
    let level = |d: u32, o: u32| sym3s(&before, at(d), at(o), n);
    let (l1, l2) = (
        level(work::LEVEL1_D, work::LEVEL1_O),
        level(work::LEVEL2_D, work::LEVEL2_O),
    );
    coarse.contrib = l1.into_iter().zip(l2).map(|(a, b)| [a, b]).collect();
    coarse.trace = w(&before, at(work::LEVEL1_O), n);
    coarse.setup(&sys.mass);
    let (diag, off) = pack_sym3s(&coarse.inv);
    let aggregates = coarse.inv.len() * 4;
    let sec = |k: u32| section(&out, at(k), n)[..aggregates].to_vec();
    assert_same("W_COARSE_INV_D", &sec(work::COARSE_INV_D), &diag);
    assert_same("W_COARSE_INV_O", &sec(work::COARSE_INV_O), &off);
}

/// What a CG kernel writes besides `work`'s vectors: the partials and CG
/// scalars, the status words and both buffers of indirect arguments.
struct CgOut {
    work: Vec<u32>,
    partials: Vec<u32>,
    status: Vec<u32>,
    apply_slots: Vec<u32>,
    update_slots: Vec<u32>,
}

/// Runs the CG kernel at dispatch `i` of `t` alone and reads what it
/// writes.
fn run_cg_kernel(t: &mut Twins, i: usize) -> CgOut {
    t.run_alone(i);
    CgOut {
        work: t.read(DebugBuffer::Work),
        partials: t.read(DebugBuffer::Partials),
        status: t.read(DebugBuffer::Status),
        apply_slots: t.read(DebugBuffer::ApplyArgs),
        update_slots: t.read(DebugBuffer::UpdateArgs),
    }
}

/// Component `c` of the first `blocks` partials of CG slot `slot` in the
/// device's `partials` words.
fn cg_partials(t: &Twins, words: &[u32], slot: u32, c: u32, blocks: usize) -> Vec<u32> {
    t.gpu.debug_layout().partial_slot(words, slot, c as usize)[..blocks].to_vec()
}

/// CG's reduction blocks of the test cloth (its per-particle kernels'
/// workgroups).
fn cg_blocks(t: &Twins) -> usize {
    t.n.div_ceil(CG_BLOCK)
}

/// The workgroups of `kernel`'s dispatches in the plan of `t`.
fn groups(t: &Twins, kernel: Kernel) -> u32 {
    let plan = t.plan();
    let d = plan
        .iter()
        .find(|d| d.kernel == kernel)
        .expect("a CG kernel");
    d.items.div_ceil(kernel.workgroup_size())
}

/// Slot `k` of `slots` enabled with `groups` workgroups, and slot `k − 1`
/// cleared.
fn assert_slot(t: &Twins, what: &str, slots: &[u32], k: usize, groups: u32) {
    let layout = t.gpu.debug_layout();
    assert_eq!(layout.arg_slot(slots, k), groups, "{what}'s slot {k}");
    if k > 0 {
        assert_eq!(
            layout.arg_slot(slots, k - 1),
            0,
            "{what}'s slot {} cleared",
            k - 1
        );
    }
}

/// cg_init's outputs against its twin's, in `t` at dispatch `i` (on a
/// grid, whose kernel computes the spring blocks from the positions: the
/// twins of implicit_springs and cg_init): the vectors, the partial sums
/// of δ0 and ρ, CG's count and stop reset, and the first cg_apply's slot.
fn check_cg_init(t: &mut Twins, i: usize) {
    load_cg_setup(t, t.grid);
    let dv = t.work_xyz(at(work::DV));
    let after = run_cg_kernel(t, i);
    let out = &after.work;
    let n = t.n;
    let blocks = cg_blocks(t);
    let apply_groups = groups(t, Kernel::CgApply);
    let (sys, _, wk) = t.parts();
    wk.dv = dv;
    cpu::cg::init(sys, wk);
    let coarse = wk.coarse.is_some();
    let sec = |k: u32| section(out, at(k), n).to_vec();
    let terms = &wk.rho_terms;
    assert_same("W_R", &sec(work::R), &pack(&wk.r, |p| terms[p]));
    if !coarse {
        assert_same("W_S", &sec(work::S), &with_kinds(&wk.s, &wk.filter));
    }
    assert_same("W_C", &sec(work::C), &vectors(&wk.c));
    assert_same("W_Q", &sec(work::Q), &vectors(&wk.q));
    let (d0, rs) = (block_words(&wk.delta0_terms), block_words(&wk.rho_terms));
    assert_eq!(d0.len(), blocks);
    let res = |c| cg_partials(t, &after.partials, partials::RES, c, blocks);
    assert_same("P_RES δ0", &res(partials::D0), &d0);
    if !coarse {
        assert_same("P_RES ρ", &res(partials::RS), &rs);
    }
    assert_eq!(after.status[status::CG_ITERATIONS], 0);
    assert_eq!(after.status[status::CG_STOPPED], 0);
    assert_slot(t, "cg_apply", &after.apply_slots, 0, apply_groups);
}

general_and!(cg_init_matches_its_twin: Implicit, coarse_grid, CgInit, 0, check_cg_init);

/// Loads the coarse levels' inverses the device holds into the mirror.
fn load_coarse(t: &mut Twins) {
    let words = t.read(DebugBuffer::Work);
    let n = t.n;
    let (_, _, wk) = t.parts();
    let Some(coarse) = wk.coarse.as_mut() else {
        return;
    };
    let total = coarse.inv.len();
    coarse.inv = sym3s(&words, at(work::COARSE_INV_D), at(work::COARSE_INV_O), n)[..total].to_vec();
}

/// The CG scalars the device holds, and its CG count and stop.
fn device_scalars(t: &Twins) -> cpu::cg::Scalars<f32> {
    let p = t.read(DebugBuffer::Partials);
    let st = t.read(DebugBuffer::Status);
    let f = |k| f32::from_bits(p[t.gpu.debug_layout().cg_scalar(k)]);
    cpu::cg::Scalars {
        delta0: f(partials::DELTA0),
        delta: f(partials::DELTA),
        alpha: f(partials::ALPHA),
        beta: f(partials::BETA),
        delta_prev: f(partials::DELTA_PREV),
        rho: 0.0,
        iterations: st[status::CG_ITERATIONS],
        stopped: st[status::CG_STOPPED] != 0,
    }
}

/// CG scalar `k`'s word in the device's `partials` words.
fn cg_scalar(t: &Twins, words: &[u32], k: u32) -> u32 {
    words[t.gpu.debug_layout().cg_scalar(k)]
}

/// cg_apply's outputs against its twin's, in `t` at dispatch `i` (a later
/// iteration, whose β counts): the residual's sums from the device's
/// partials (with coarse levels its per-slot ones, and the level-2
/// corrections the twin adds to `s` first), the direction and product,
/// cᵀq's partial sums, the scalars and cg_update's slot. On a grid the
/// kernel computes the spring blocks from the positions: its twin is then
/// implicit_springs' and cg_apply's.
fn check_cg_apply(t: &mut Twins, i: usize) {
    // A grid cloth's springs keep their grid slots on the general kernels
    // too: the blocks then come from the mirror's own spring pass.
    let grid_cloth = t.grid || t.parts().2.coarse.is_some();
    load_cg_setup(t, grid_cloth);
    load_coarse(t);
    let before = t.read(DebugBuffer::Work);
    let partials_before = t.read(DebugBuffer::Partials);
    let scalars = device_scalars(t);
    assert!(scalars.iterations > 0, "a later iteration, whose β counts");
    let after = run_cg_kernel(t, i);
    let n = t.n;
    let blocks = cg_blocks(t);
    let update_groups = groups(t, Kernel::CgUpdate);
    let slot_partials = |c| {
        let words = t
            .gpu
            .debug_layout()
            .partial_slot(&partials_before, partials::RES, c as usize);
        words
            .iter()
            .map(|&w| f32::from_bits(w))
            .collect::<Vec<f32>>()
    };
    let (rs, dc) = (slot_partials(partials::RS), slot_partials(partials::DC));
    let (sys, _, wk) = t.parts();
    wk.s = xyz(&before, at(work::S), n);
    wk.c = xyz(&before, at(work::C), n);
    wk.q = xyz(&before, at(work::Q), n);
    wk.rho_terms = w(&before, at(work::R), n);
    wk.cg = scalars;
    if let Some(coarse) = wk.coarse.as_mut() {
        let (n1, n2, k) = (coarse.r1.len(), coarse.z2.len(), coarse.rho_partials.len());
        coarse.z2 = xyz(&before, at(work::COARSE_Z), n)[n1..n1 + n2].to_vec();
        coarse.rho_partials = rs[..k].to_vec();
        coarse.dc_partials = dc[..k].to_vec();
    }
    cpu::cg::apply(sys, wk);
    let cg = wk.cg;
    assert!(!cg.stopped, "the test's CG runs on");
    let terms = &wk.cq_terms;
    assert_same("W_C", section(&after.work, at(work::C), n), &vectors(&wk.c));
    assert_same(
        "W_Q",
        section(&after.work, at(work::Q), n),
        &pack(&wk.q, |p| terms[p]),
    );
    let cq = block_words(&wk.cq_terms);
    assert_same(
        "P_CQ",
        &cg_partials(t, &after.partials, partials::CQ, 0, blocks),
        &cq,
    );
    let scalars = [partials::DELTA, partials::BETA].map(|k| cg_scalar(t, &after.partials, k));
    assert_same("δ, β", &scalars, &bits(&[cg.delta, cg.beta]));
    assert_eq!(after.status[status::CG_STOPPED], 0, "stopped");
    let k = cg.iterations as usize;
    assert_eq!(after.status[status::UPDATE_SLOT], k as u32);
    assert_slot(t, "cg_update", &after.update_slots, k, update_groups);
}

general_and!(cg_apply_matches_its_twin: Implicit, coarse_grid, CgApply, 1, check_cg_apply);

#[test]
fn cg_apply_with_coarse_levels_on_the_general_kernels_matches_its_twin() {
    let mut t = coarse_general();
    let i = t.run_to(Kernel::CgApply, 2);
    check_cg_apply(&mut t, i);
}

/// cg_update's outputs against its twin's, in `t` at dispatch `i`: Δv, r,
/// s, ρ's partial sums (with coarse levels both levels' sums and
/// corrections and the per-slot partials), and outside the first variant
/// α, the count and the next cg_apply's slot.
fn check_cg_update(t: &mut Twins, i: usize) {
    let first = t.plan()[i].variant == Variant::CgFirst;
    load_cg_setup(t, false);
    load_coarse(t);
    let scalars = device_scalars(t);
    let before = t.read(DebugBuffer::Work);
    let after = run_cg_kernel(t, i);
    let n = t.n;
    let blocks = cg_blocks(t);
    let apply_groups = groups(t, Kernel::CgApply);
    let layout = t.gpu.debug_layout();
    let res = |c, len: usize| {
        layout.partial_slot(&after.partials, partials::RES, c as usize)[..len].to_vec()
    };
    let (_, _, wk) = t.parts();
    let v = |k: u32| xyz(&before, at(k), n);
    (wk.dv, wk.r, wk.c, wk.q) = (v(work::DV), v(work::R), v(work::C), v(work::Q));
    wk.cq_terms = w(&before, at(work::Q), n);
    wk.cg = scalars;
    cpu::cg::update(wk, first);
    let cg = wk.cg;
    let sec = |k: u32| section(&after.work, at(k), n);
    let terms = &wk.rho_terms;
    assert_same("W_DV", sec(work::DV), &with_kinds(&wk.dv, &wk.filter));
    assert_same("W_R", sec(work::R), &pack(&wk.r, |p| terms[p]));
    assert_same("W_S", sec(work::S), &with_kinds(&wk.s, &wk.filter));
    if let Some(coarse) = &wk.coarse {
        let (n1, n2) = (coarse.r1.len(), coarse.z2.len());
        assert_same(
            "level-1 W_COARSE_Z",
            &sec(work::COARSE_Z)[..n1 * 4],
            &pack(&coarse.r1, |a| coarse.term1[a]),
        );
        assert_same(
            "level-2 W_COARSE_Z",
            &sec(work::COARSE_Z)[n1 * 4..(n1 + n2) * 4],
            &pack(&coarse.z2, |k| coarse.term2[k]),
        );
        let k = coarse.rho_partials.len();
        assert_same(
            "P_RES ρ",
            &res(partials::RS, k),
            &bits(&coarse.rho_partials),
        );
        assert_same(
            "P_RES coarse",
            &res(partials::DC, k),
            &bits(&coarse.dc_partials),
        );
    } else {
        assert_same(
            "P_RES ρ",
            &res(partials::RS, blocks),
            &block_words(&wk.rho_terms),
        );
    }
    if first {
        return;
    }
    assert!(!cg.stopped, "the test's CG runs on");
    let alpha = [cg_scalar(t, &after.partials, partials::ALPHA)];
    assert_same("α", &alpha, &bits(&[cg.alpha]));
    let prev = [cg_scalar(t, &after.partials, partials::DELTA_PREV)];
    assert_same("δ_prev", &prev, &bits(&[cg.delta_prev]));
    assert_eq!(
        after.status[status::CG_ITERATIONS],
        cg.iterations,
        "iterations"
    );
    assert_slot(
        t,
        "cg_apply",
        &after.apply_slots,
        cg.iterations as usize,
        apply_groups,
    );
}

#[test]
fn cg_update_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::Implicit, true, Kernel::CgUpdate, 1);
    check_cg_update(&mut t, i);
    // With coarse levels: the first variant, then an iteration's.
    let mut t = coarse(false);
    let i = t.run_to(Kernel::CgUpdate, 0);
    assert_eq!(t.plan()[i].variant, Variant::CgFirst);
    check_cg_update(&mut t, i);
    let j = t.plan()[i + 1..]
        .iter()
        .position(|d| d.kernel == Kernel::CgUpdate)
        .map(|k| i + 1 + k)
        .expect("an iteration");
    t.gpu
        .debug_run(i + 1..j)
        .expect("up to the iteration's cg_update");
    check_cg_update(&mut t, j);
}

/// implicit_finish's outputs against its twin's, in `t` at dispatch `i`
/// (on a grid, whose kernel computes the blocks its contacts need from the
/// start-of-step positions: the twins of implicit_springs and
/// implicit_finish).
fn check_implicit_finish(t: &mut Twins, i: usize) {
    load_cg_setup(t, t.grid);
    let dv = t.work_xyz(at(work::DV));
    t.run_alone(i);
    let (x, v) = (t.read(DebugBuffer::X), t.read(DebugBuffer::V));
    let (inv_mass, mass) = t.masses();
    let (sys, st, wk) = t.parts();
    wk.dv = dv;
    let planes = wk
        .filter
        .iter()
        .filter(|f| matches!(f, Filter::Plane(..)))
        .count();
    assert!(
        planes > 0,
        "the test cloth rests on a collider somewhere (friction)"
    );
    cpu::implicit::finish(sys, st, wk);
    assert_same("x", &x, &pack(&st.x, |p| inv_mass[p]));
    assert_same("v", &v, &pack(&st.v, |p| mass[p]));
    let wk = t.parts().2;
    let (held, friction) = (wk.held.clone(), vectors(&wk.friction));
    assert_eq!(device_held(t), held, "W_DV_PREV's held flags");
    assert_same(
        "W_CLOCK's friction",
        &vectors(&device_friction(t)),
        &friction,
    );
}

general_and!(implicit_finish_matches_its_twin: Implicit, coarse_grid, ImplicitFinish, 0, check_implicit_finish);

/// semi_rhs's outputs against its twin's, in `t` at dispatch `i` (on a
/// grid: the twins of spring_forces and semi_rhs).
fn check_semi_rhs(t: &mut Twins, i: usize) {
    let variant = t.plan()[i].variant;
    assert_eq!(variant, Variant::Plain, "the dense filter's variant");
    t.load_state();
    load_forces(t);
    t.run_alone(i);
    let out = t.read(DebugBuffer::Work);
    let n = t.n;
    let (sys, st, wk) = t.parts();
    assert!(sys.torque_compensation, "the busy scene compensates");
    cpu::semi_implicit::rhs(sys, st, wk, true);
    assert_same("W_RHS", section(&out, at(work::RHS), n), &vectors(&wk.rhs));
    assert_same("W_DV", section(&out, at(work::DV), n), &vectors(&wk.dv));
    // The per-spring compensation changes the right-hand side here (some
    // springs are stretched), so the comparison above covers it.
    let compensated = wk.rhs.clone();
    let uncompensated = cpu::System {
        torque_compensation: false,
        ..sys.clone()
    };
    cpu::semi_implicit::rhs(&uncompensated, st, wk, true);
    assert_ne!(
        vectors(&compensated),
        vectors(&wk.rhs),
        "the compensation left the right-hand side unchanged"
    );
}

general_and!(semi_rhs_matches_its_twin: SemiImplicit, semi_grid, SemiRhs, 0, check_semi_rhs);

#[test]
fn filter_dense_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::SemiImplicit, true, Kernel::FilterDense, 0);
    let (rhs, dv) = (t.work_xyz(at(work::RHS)), t.work_xyz(at(work::DV)));
    t.run_alone(i);
    let out = t.read(DebugBuffer::Work);
    let n = t.n;
    let (_, _, wk) = t.parts();
    let Some(cpu::ConstantFilter::Dense(filter)) = &wk.constant_filter else {
        panic!("the test cloth's filter is dense");
    };
    let mut got = dv;
    filter.apply(&rhs, &mut got, &mut wk.scratch);
    assert_same("W_DV", section(&out, at(work::DV), n), &vectors(&got));
}

/// The torque partial slots `slots` (from the first torque slot) of the
/// device's partials `p`.
fn torque_words(t: &Twins, p: &[u32], slots: std::ops::Range<u32>) -> Vec<u32> {
    slots
        .flat_map(|k| {
            t.gpu
                .debug_layout()
                .partial_slot(p, partials::TORQUE + k, 0)
        })
        .collect()
}

/// The mirror's torque partial slots `slots`.
fn cpu_torque_words(torque: &[f32], slots: std::ops::Range<usize>) -> Vec<u32> {
    let blocks = torque.len() / cpu::torque::SLOTS;
    bits(&torque[slots.start * blocks..slots.end * blocks])
}

/// The first slot of the moments and the number of slots.
const TORQUE_MOMENTS: usize = 4;

/// Loads the device's torque partials into the mirror.
fn load_torque(t: &mut Twins) {
    let p = t.read(DebugBuffer::Partials);
    let words = torque_words(t, &p, 0..cpu::torque::SLOTS as u32);
    let (_, _, wk) = t.parts();
    wk.torque = words.into_iter().map(f32::from_bits).collect();
}

#[test]
fn torque_centre_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::SemiImplicit, false, Kernel::TorqueCentre, 0);
    t.load_state();
    t.run_alone(i);
    let p = t.read(DebugBuffer::Partials);
    let (sys, st, wk) = t.parts();
    cpu::torque::centre(sys, &st.x, &mut wk.torque);
    let want = cpu_torque_words(&wk.torque, 0..TORQUE_MOMENTS);
    assert_same(
        "Σ m, Σ m x",
        &torque_words(&t, &p, 0..TORQUE_MOMENTS as u32),
        &want,
    );
}

#[test]
fn torque_moments_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::SemiImplicit, false, Kernel::TorqueMoments, 0);
    t.load_state();
    load_torque(&mut t);
    let dv = t.work_xyz(at(work::DV));
    t.run_alone(i);
    let p = t.read(DebugBuffer::Partials);
    let (sys, st, wk) = t.parts();
    cpu::forces::external_forces(sys, &st.x, &st.v, &mut wk.per_triangle, &mut wk.force);
    cpu::torque::moments(sys, &st.x, &dv, &wk.force, &mut wk.torque);
    let slots = TORQUE_MOMENTS..cpu::torque::SLOTS;
    let want = cpu_torque_words(&wk.torque, slots.clone());
    let got = torque_words(&t, &p, slots.start as u32..slots.end as u32);
    assert_same("moments and inertia", &got, &want);
}

#[test]
fn torque_apply_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::SemiImplicit, false, Kernel::TorqueApply, 0);
    t.load_state();
    load_torque(&mut t);
    let mut dv = t.work_xyz(at(work::DV));
    t.run_alone(i);
    let out = t.read(DebugBuffer::Work);
    let n = t.n;
    let (_, st, wk) = t.parts();
    let before = dv.clone();
    cpu::torque::apply(&st.x, &wk.torque, &mut dv);
    assert_ne!(
        dv, before,
        "the free cloth's Δv has a spurious rotation to remove"
    );
    assert_same("W_DV", section(&out, at(work::DV), n), &vectors(&dv));
}

#[test]
fn semi_integrate_matches_its_twin() {
    let (mut t, i) = general_at(Integrator::SemiImplicit, true, Kernel::SemiIntegrate, 0);
    t.load_state();
    let dv = t.work_xyz(at(work::DV));
    check_prediction(&mut t, i, |wk| wk.dv = dv, cpu::semi_implicit::integrate);
}

/// Bending stiffness \[N·m\] and damping \[s\] of the test cloth's linear
/// bending model: enough to change its CG matrix's diagonal and products
/// well beyond rounding.
const BENDING: (f64, f64) = (1e-3, 0.005);

/// The busy semi-implicit scene on the general kernels with its filter
/// solved by CG on the device ([`FilterMethod::Banded`]), and with the
/// linear bending model (`Bending::grid`) where `bending`. The CPU solves
/// the filter exactly: the two differ by the CG's tolerance, so the state
/// is not compared.
fn semi_cg(bending: bool) -> Twins {
    let mut p = params(Integrator::SemiImplicit);
    p.semi_implicit.filter = FilterMethod::Banded;
    let mut model = without_grid(&grid(NX, NY, corners(), &p));
    if bending {
        let (hx, hy) = (1.0 / (NX - 1) as f64, 1.0 / (NY - 1) as f64);
        let b = wgcloth::bending::Bending::grid(NX, NY, hx, hy, BENDING.0, BENDING.1, &[]);
        model.bending = Some(b.unwrap_or_else(|e| panic!("bending: {e}")));
    }
    Twins::unchecked(&model, &p, false, WARM_STEPS)
}

#[test]
fn semi_cg_prepare_matches_its_twin() {
    let mut t = semi_cg(false);
    let i = t.run_to(Kernel::SemiCgPrepare, 0);
    check_semi_cg_prepare(&mut t, i);
}

/// The semi-implicit filter solved by CG on a cloth with the linear
/// bending model: its set-up (the preconditioner's diagonal carries
/// `(dt² + dt β) Q_pp`) and its product (`(dt² + dt β) Q c`) as their
/// twins'. (Every other path is compared whole step against the mirror in
/// `tests/gpu_bending.rs`.)
#[test]
fn the_cg_filter_carries_the_bending_operator_as_its_twins() {
    let check: fn(&mut Twins, usize) = check_semi_cg_prepare;
    for (kernel, nth, check) in [
        (Kernel::SemiCgPrepare, 0, check),
        (Kernel::CgApply, 1, check_cg_apply),
    ] {
        let mut t = semi_cg(true);
        let i = t.run_to(kernel, nth);
        check(&mut t, i);
    }
}

/// semi_cg_prepare's outputs against its twin's, in `t` at dispatch `i`.
fn check_semi_cg_prepare(t: &mut Twins, i: usize) {
    let spring_words = t.read(DebugBuffer::SpringWork);
    let before = t.read(DebugBuffer::Work);
    t.run_alone(i);
    let (out, flags) = (t.read(DebugBuffer::Work), t.read(DebugBuffer::Status));
    let n = t.n;
    let (sys, _, wk) = t.parts();
    wk.blocks = blocks(&spring_words, at(spring_work::BLOCK), sys);
    wk.rhs = xyz(&before, at(work::RHS), n);
    wk.dv = xyz(&before, at(work::DV), n);
    wk.dv_prev = xyz(&before, at(work::DV_PREV), n);
    cpu::semi_implicit::cg_prepare(sys, wk);
    assert_cg_setup(&out, &flags, wk, n);
}

/// The status words the host reads after a submit (`GpuSolver::check`):
/// the step count, the first non-finite step and particle, CG's counts
/// and the fix-up's passes.
const HOST_STATUS: [usize; 6] = [
    status::STEP,
    status::BAD_STEP,
    status::BAD_PARTICLE,
    status::CG_ITERATIONS,
    status::CG_MAX_ITERATIONS,
    status::FIXUP_PASSES,
];

/// Steps compared after the first: enough for the busy scene's fix-up to
/// stop early in some steps and run every pass in others.
const WORKGROUP_STEPS: u32 = 40;

/// A workgroup kernel's twin is the CPU solver's whole step: after 1 and
/// after [`WORKGROUP_STEPS`] steps of the busy scene for `integrator`
/// (general layout, pinned or free), every particle's x and v agree with
/// the mirror's under the policy (bit for bit; or each step, the mirror
/// re-seeded, within one step's bound), and under bits the status words
/// the host reads equal the multi-dispatch path's (whose own twins are the
/// tests above).
fn check_workgroup_step(integrator: Integrator, pinned: bool, kernel: Kernel) {
    let p = params(integrator);
    let pins = if pinned { corners() } else { Vec::new() };
    let model = without_grid(&grid(NX, NY, pins, &p));
    let mut wg = Twins::on_path(&model, &p, true, 0, StepPath::Workgroup);
    let plan = wg.plan();
    assert!(
        plan.len() == 1 && plan[0].kernel == kernel,
        "one dispatch of {kernel} per step: {plan:?}"
    );
    if agreement::policy() == Policy::Bounded {
        agreement::check_reseeded(
            &format!("{kernel}"),
            &mut wg.gpu,
            &mut wg.cpu,
            WORKGROUP_STEPS,
            &agreement::step_bound(&p),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        return;
    }
    let mut md = Twins::on_path(&model, &p, true, 0, StepPath::MultiDispatch);
    let mut done = 0;
    for steps in [1, WORKGROUP_STEPS - 1] {
        wg.gpu
            .step(steps)
            .unwrap_or_else(|e| panic!("{kernel}: {e}"));
        md.gpu
            .step(steps)
            .unwrap_or_else(|e| panic!("multi-dispatch: {e}"));
        wg.cpu
            .step_n(u64::from(steps))
            .unwrap_or_else(|e| panic!("CPU: {e}"));
        done += steps;
        wg.assert_states_agree(&format!("after {done} steps of {kernel}"));
        let (a, b) = (wg.read(DebugBuffer::Status), md.read(DebugBuffer::Status));
        let words = |s: &[u32]| HOST_STATUS.map(|k| s[k]);
        assert_eq!(
            words(&a),
            words(&b),
            "status words {HOST_STATUS:?} after {done} steps: {kernel}, multi-dispatch"
        );
    }
}

#[test]
fn cloth_explicit_matches_its_twin() {
    check_workgroup_step(Integrator::Explicit, true, Kernel::ClothExplicit);
}

#[test]
fn cloth_implicit_matches_its_twin() {
    check_workgroup_step(Integrator::Implicit, true, Kernel::ClothImplicit);
}

/// Pinned (the per-spring torque compensation) and free (the global
/// torque passes, whose sums the kernel reduces itself).
#[test]
fn cloth_semi_implicit_matches_its_twin() {
    for pinned in [true, false] {
        check_workgroup_step(Integrator::SemiImplicit, pinned, Kernel::ClothSemiImplicit);
    }
}

/// Steps of the folded drop before the self-collision twins run: the
/// stack lands at about 60 steps, and by 90 its layers press on one
/// another, so the passes have contacts to resolve.
const FOLDED_WARM: u32 = 90;

/// The folded cloth of tests/self_collision.rs mid-drop, with
/// self-collision at its defaults, on the multi-dispatch path (the GPU's
/// Jacobi fix-up on both sides). Its states are not compared here (the
/// whole drop is, in tests/self_collision.rs): every twin below reads its
/// inputs from the device.
fn folded(integrator: Integrator) -> Twins {
    let model = folded_model();
    let mut params = Params {
        integrator,
        dt: 1.0 / 600.0,
        ground: Some(wgcloth::params::Ground {
            height: 0.0,
            friction: 0.5,
        }),
        self_collision: Some(wgcloth::params::SelfCollision::default()),
        ..Params::default()
    };
    params.fixup.method = wgcloth::params::FixupMethod::Jacobi;
    params.implicit.max_iterations = 40;
    let mut t = Twins::unchecked(&model, &params, true, 0);
    let start = folded_positions(0.05);
    for (p, x) in start.iter().enumerate() {
        t.gpu.set_position(p, x.as_vec3()).expect("position");
    }
    t.cpu
        .set_state(cpu::State {
            x: start.iter().map(|&p| Vec3::from_f64(p)).collect(),
            v: vec![Vec3::ZERO; start.len()],
        })
        .expect("state");
    t.gpu.step(FOLDED_WARM).expect("GPU steps");
    t.cpu.step_n(u64::from(FOLDED_WARM)).expect("CPU steps");
    t
}

/// The mirror's self-collision and its grid built from positions `x`.
fn cpu_grid(
    t: &mut Twins,
    x: &[Vec3<f32>],
) -> (
    cpu::self_collision::SelfCollisionR<f32>,
    cpu::self_collision::Grid<f32>,
) {
    let (sys, _, wk) = t.parts();
    let c = sys.self_collision.clone().expect("self-collision on");
    let mut g = wk.self_grid.clone().expect("its grid");
    cpu::self_collision::build(&c, x, &mut g);
    (c, g)
}

/// The first `n` entries' x words of section `sec` (the grid's indices).
fn first_words(words: &[u32], sec: u32, n: usize) -> Vec<u32> {
    section(words, at(sec), n).chunks(4).map(|e| e[0]).collect()
}

/// The bucket counters after the status words.
fn counters(t: &Twins, table: usize) -> Vec<u32> {
    t.read(DebugBuffer::Status)[status::COUNT..status::COUNT + table].to_vec()
}

#[test]
fn self_collision_count_matches_its_twin() {
    // The explicit step's source is the fix-up's result, the implicit
    // one's its prediction.
    for integrator in [Explicit, Implicit] {
        let mut t = folded(integrator);
        let i = t.run_to(Kernel::SelfCollisionCount, 0);
        let flags = t.read(DebugBuffer::Status);
        let predicted = t.work_xyz(at(flags[status::FIXUP_RESULT]));
        t.run_alone(i);
        let work = t.read(DebugBuffer::Work);
        let (c, g) = cpu_grid(&mut t, &predicted);
        let n = t.n;
        assert_same(
            "W_SC_A",
            section(&work, at(work::SC_A), n),
            &vectors(&predicted),
        );
        let cells: Vec<u32> = g
            .cell
            .iter()
            .flat_map(|k| {
                let b = cpu::self_collision::bucket(*k, c.table) as u32;
                [k[0] as u32, k[1] as u32, k[2] as u32, b]
            })
            .collect();
        assert_exact("W_SC_CELL", section(&work, at(work::SC_CELL), n), &cells);
        let counts: Vec<u32> = (0..c.table).map(|b| g.start[b + 1] - g.start[b]).collect();
        assert_exact("bucket counters", &counters(&t, c.table), &counts);
    }
}

/// The folded explicit drop after the build kernel `kernel` ran alone:
/// the twins, the device's `work` words and the mirror's grid built from
/// the positions the device's build started from.
fn after_build_kernel(
    kernel: Kernel,
) -> (
    Twins,
    Vec<u32>,
    cpu::self_collision::SelfCollisionR<f32>,
    cpu::self_collision::Grid<f32>,
) {
    let mut t = folded(Explicit);
    let i = t.run_to(kernel, 0);
    let built = t.work_xyz(at(work::SC_A));
    t.run_alone(i);
    let words = t.read(DebugBuffer::Work);
    let (c, g) = cpu_grid(&mut t, &built);
    (t, words, c, g)
}

#[test]
fn self_collision_scan_matches_its_twin() {
    let (t, work, c, g) = after_build_kernel(Kernel::SelfCollisionScan);
    let runs: Vec<u32> = (0..c.table / 2)
        .flat_map(|k| {
            let s = &g.start[2 * k..2 * k + 3];
            [s[0], s[1], s[1], s[2]]
        })
        .collect();
    let words = section(&work, at(work::SC_BUCKETS), t.n);
    assert_exact("W_SC_BUCKETS", &words[..runs.len()], &runs);
}

#[test]
fn self_collision_scatter_matches_its_twin() {
    let (t, work, c, g) = after_build_kernel(Kernel::SelfCollisionScatter);
    // Each run holds its bucket's particles in whatever order the atomics
    // left them: the same set as the twin's.
    let scattered = first_words(&work, work::SC_UNORDERED, t.n);
    let mut several = 0;
    for b in 0..c.table {
        let run = g.start[b] as usize..g.start[b + 1] as usize;
        let mut got = scattered[run.clone()].to_vec();
        got.sort_unstable();
        assert_eq!(got, g.order[run.clone()], "bucket {b}'s run");
        several += usize::from(run.len() > 1);
    }
    assert!(
        several > 0,
        "no bucket holds several particles: the ranking is untested"
    );
    assert_eq!(
        counters(&t, c.table),
        vec![0; c.table],
        "the counters end at zero"
    );
}

#[test]
fn self_collision_rank_matches_its_twin() {
    let (t, work, _, g) = after_build_kernel(Kernel::SelfCollisionRank);
    let ordered: Vec<u32> = g
        .order
        .iter()
        .flat_map(|&q| {
            let k = g.cell[q as usize];
            [q, k[0] as u32, k[1] as u32, k[2] as u32]
        })
        .collect();
    assert_exact(
        "W_SC_ORDER",
        section(&work, at(work::SC_ORDER), t.n),
        &ordered,
    );
}

#[test]
fn self_collision_respond_matches_its_twin() {
    for integrator in [Explicit, Implicit] {
        let mut t = folded(integrator);
        let passes = t
            .cpu
            .system()
            .self_collision
            .as_ref()
            .map_or(0, |c| c.iterations);
        assert!(passes >= 2, "the default passes: a first and a last");
        let mut contacts = false;
        for k in 0..passes {
            let i = t.run_to(Kernel::SelfCollisionRespond, k as usize);
            let last = k + 1 == passes;
            let flags = t.read(DebugBuffer::Status);
            let src = match k {
                0 => work::SC_A,
                k if k % 2 == 1 => work::SC_B,
                _ => work::SC_C,
            };
            let dst = match (last, k % 2) {
                (true, _) => flags[status::FIXUP_RESULT],
                (false, 0) => work::SC_B,
                (false, _) => work::SC_C,
            };
            let built = t.work_xyz(at(work::SC_A));
            let snapshot = t.work_xyz(at(src));
            let x_old = xyz(&t.read(DebugBuffer::X), 0, t.n);
            t.run_alone(i);
            let out = t.work_xyz(at(dst));
            let moved_flag = t.read(DebugBuffer::Status)[status::FIXUP_MOVED] != 0;
            let (c, mut g) = cpu_grid(&mut t, &built);
            g.snapshot = snapshot;
            let sys = t.cpu.system();
            let results: Vec<_> = (0..t.n)
                .map(|p| cpu::self_collision::pass(sys, &c, &g, &x_old, p, last))
                .collect();
            let want: Vec<Vec3<f32>> = results.iter().map(|r| r.0).collect();
            assert_same(
                &format!("{integrator} pass {k}"),
                &vectors(&out),
                &vectors(&want),
            );
            let moved = results.iter().any(|r| r.1);
            assert!(
                !moved || moved_flag,
                "{integrator} pass {k}: moved, not flagged"
            );
            contacts |= moved;
        }
        assert!(
            contacts,
            "{integrator}: the passes found no contact to test"
        );
    }
}

// Render meshes: the vertex normals and the `skin` pass.

/// The `skin` pass's words against its twin's from the same cloth, under
/// the bounded policy: a normal's path holds four normalisations (the
/// cloth's vertex normal, the interpolated `n̂`, `t̂`, the result), each a
/// square root and a division within 2.5 ulp: 20 units, plus the final
/// rounding, under 32; the fused products as in [`agreement::KERNEL`]
/// (fewer than 64 on any word's path). Errors spread evenly up to the
/// worst case have a root mean square of 20/√3 ≈ 11.5 units: 12.
const SKIN: Bound = Bound {
    ulps: 32.0,
    rel: 64.0,
    rms_ulps: 12.0,
    drift: None,
};

/// The `normals` kernel against its twin, under both policies: a sum of
/// six cross products, a square root and a division, one kernel's
/// ([`agreement::KERNEL`]), each component measured in ulps of the unit
/// vector's length. On lavapipe about half the words differ from the twin
/// by an ulp or so of that length (neither the twin's order, nor its
/// fused variants, nor the other triangle and corner orders give the
/// device's bits), so the bits policy cannot hold here.
const NORMALS: Bound = agreement::KERNEL;

/// The cloth's positions and the vertex normals its last normals pass
/// wrote, read back.
fn positions_and_normals(solver: &wgcloth::GpuSolver) -> (Vec<Vec3<f32>>, Vec<Vec3<f32>>) {
    let state = solver.read_state().expect("state");
    let x: Vec<Vec3<f32>> = state.x.iter().map(|p| Vec3::new(p.x, p.y, p.z)).collect();
    let normals = read_normals(solver.normals_buffer(), 0, x.len());
    (x, normals)
}

/// `count` vertex normals (`vec4<f32>`) of `buffer` from vertex `first`.
fn read_normals(buffer: &wgpu::Buffer, first: u64, count: usize) -> Vec<Vec3<f32>> {
    let ctx = gpu_common::gpu();
    let read = readback::read_buffers(
        &ctx.device,
        &ctx.queue,
        &[(buffer, first * 16, (count * 16) as u64)],
    )
    .expect("normals read-back");
    let words: Vec<f32> = bytemuck::pod_collect_to_vec(&read[0]);
    words
        .chunks(4)
        .map(|n| Vec3::new(n[0], n[1], n[2]))
        .collect()
}

#[test]
fn normals_matches_its_twin() {
    let params = params(Explicit);
    let model = grid(NX, NY, corners(), &params);
    let ctx = gpu_common::gpu();
    let mut solver = wgcloth::GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params)
        .expect("GPU solver");
    solver.step(WARM_STEPS * 10).expect("steps");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    solver.encode_normals(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let (x, normals) = positions_and_normals(&solver);
    let gpu: Vec<f32> = normals.iter().flat_map(|n| [n.x, n.y, n.z]).collect();
    let twin: Vec<f32> = skin::normals(&model, &x)
        .iter()
        .flat_map(|n| [n.x, n.y, n.z])
        .collect();
    // Each component of a unit vector is as exact as the vector: measured
    // in ulps of 1, its length.
    let unit = agreement::ulp_of(1.0);
    agreement::check_values_with("vertex normals", &gpu, &twin, 1.0, &NORMALS, |_| unit)
        .unwrap_or_else(|e| panic!("{e}"));
}

/// Words 0 and 4 of each vertex are left out of the skin tests' layout:
/// the pass must not touch them.
const SKIN_LAYOUT: SkinLayout = SkinLayout {
    stride: 8,
    position: 1,
    normal: Some(5),
    uv: None,
};

/// The skin tests' cloth after 300 steps on a lone solver, its two-layer
/// render mesh's embedding and that render mesh in [`SKIN_LAYOUT`].
fn skinned_solver() -> (
    wgcloth::Model,
    wgcloth::render_mesh::Embedding,
    wgcloth::GpuSolver,
    GpuRenderMesh,
) {
    let params = params(Explicit);
    let model = grid(13, 9, corners(), &params);
    let (_, embedding) = embedded(&model);
    let ctx = gpu_common::gpu();
    let mut solver = wgcloth::GpuSolver::with_kernels(ctx.kernels(), &ctx.queue, &model, &params)
        .expect("GPU solver");
    solver.step(300).expect("steps");
    let mesh = GpuRenderMesh::new(&solver, &embedding, SKIN_LAYOUT).expect("render mesh");
    (model, embedding, solver, mesh)
}

#[test]
fn skin_matches_its_twin() {
    let ctx = gpu_common::gpu();
    let params = params(Explicit);
    let layout = SKIN_LAYOUT;
    // A lone solver's cloth.
    let (model, embedding, solver, mesh) = skinned_solver();
    skin_and_check("a solver's cloth", &model, &embedding, &solver, &mesh, 0.0);
    // The second cloth of a batch: its indices and vertices past the
    // first cloth's.
    let mut batch = wgcloth::gpu::GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
    batch
        .add(&grid(5, 4, corners(), &params), &params)
        .expect("first cloth");
    let id = batch.add(&model, &params).expect("second cloth");
    batch.step(300).expect("steps");
    let mesh = GpuRenderMesh::in_batch(&batch, id, &embedding, layout).expect("render mesh");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    batch.encode_normals(&mut encoder);
    mesh.encode(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let state = batch.read_state(id).expect("state");
    let x: Vec<Vec3<f32>> = state.x.iter().map(|p| Vec3::new(p.x, p.y, p.z)).collect();
    let range = batch.draw_range(id).expect("the cloth's range");
    let first = u64::try_from(range.base_vertex).expect("a vertex");
    let normals = read_normals(range.normals, first, x.len());
    assert!(range.base_vertex > 0 && range.indices.start > 0);
    check_skin(
        "a batch's second cloth",
        &model,
        &embedding,
        &mesh,
        &x,
        &normals,
        0.0,
    );
}

/// A word no pass writes (`-1.5`: neither a position of these cloths nor
/// a unit normal's component, nor zero, which the render mesh's own
/// buffer starts with).
const HOST_BLANK: f32 = -1.5;

/// A host's buffer of [`HOST_BLANK`] words with room for the mesh at
/// byte `offset` and 64 words after it.
fn host_buffer(
    ctx: &wgcloth::gpu::GpuContext,
    offset: u64,
    vertices: usize,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    let words = offset as usize / 4 + vertices * 8 + 64;
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("test host vertices"),
            contents: bytemuck::cast_slice(&vec![HOST_BLANK; words]),
            usage,
        })
}

#[test]
fn skin_writes_into_a_host_buffer() {
    let ctx = gpu_common::gpu();
    let layout = SKIN_LAYOUT;
    let (model, embedding, solver, mut mesh) = skinned_solver();
    let n = embedding.vertex_count();
    // Past a storage-offset boundary by a word: the binding starts at the
    // boundary and the kernel adds the word.
    let offset = 260;
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let host = host_buffer(ctx, offset, n, usage);
    // Refusals first: the mesh keeps its own buffer after each.
    let refused = [
        (
            host_buffer(ctx, offset, n, wgpu::BufferUsages::COPY_SRC),
            offset,
            layout,
            "STORAGE",
        ),
        (host.clone(), offset + 2, layout, "a multiple of 4"),
        (host.clone(), host.size() - 4, layout, "room for"),
        (
            host.clone(),
            offset,
            SkinLayout {
                uv: Some(6),
                ..layout
            },
            "texture coordinates",
        ),
    ];
    for (buffer, at, l, says) in &refused {
        let e = mesh
            .write_into(buffer, *at, *l)
            .expect_err("a bad target")
            .to_string();
        assert!(e.contains(says), "{e}: should say {says}");
        assert_eq!(mesh.vertex_offset(), 0, "{e}");
    }
    mesh.write_into(&host, offset, layout)
        .expect("the host's buffer");
    assert_eq!(
        (mesh.vertex_buffer(), mesh.vertex_offset()),
        (&host, offset)
    );
    skin_and_check(
        "a host's buffer",
        &model,
        &embedding,
        &solver,
        &mesh,
        HOST_BLANK,
    );
    // Nothing before the mesh or after it was written.
    let all: Vec<f32> = bytemuck::pod_collect_to_vec(
        &readback::read_buffers(&ctx.device, &ctx.queue, &[(&host, 0, host.size())])
            .expect("read-back")[0],
    );
    let (head, rest) = all.split_at(offset as usize / 4);
    let tail = &rest[n * 8..];
    assert!(
        head.iter().chain(tail).all(|&w| w == HOST_BLANK),
        "a word outside the render mesh's range of the host's buffer was written"
    );
}

/// Records `solver`'s normals and `mesh`'s pass, and checks what it wrote
/// ([`check_skin`]).
fn skin_and_check(
    what: &str,
    model: &wgcloth::Model,
    embedding: &wgcloth::render_mesh::Embedding,
    solver: &wgcloth::GpuSolver,
    mesh: &GpuRenderMesh,
    blank: f32,
) {
    let ctx = gpu_common::gpu();
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    solver.encode_normals(&mut encoder);
    mesh.encode(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let (x, normals) = positions_and_normals(solver);
    check_skin(what, model, embedding, mesh, &x, &normals, blank);
}

/// The vertex buffer `mesh`'s pass wrote (of the layout of
/// [`skin_matches_its_twin`]) against the twin from the same positions
/// `x` and normals; the words outside the layout must still be `blank`.
fn check_skin(
    what: &str,
    model: &wgcloth::Model,
    embedding: &wgcloth::render_mesh::Embedding,
    mesh: &GpuRenderMesh,
    x: &[Vec3<f32>],
    normals: &[Vec3<f32>],
    blank: f32,
) {
    let words = mesh.read_vertices().expect("read-back");
    let (p, n): (Vec<_>, Vec<_>) = embedding
        .vertices
        .iter()
        .map(|e| skin::skin_vertex(model, x, normals, e))
        .unzip();
    let mut gpu_words = Vec::new();
    let mut cpu_words = Vec::new();
    for (k, (p, n)) in p.iter().zip(&n).enumerate() {
        let at = k * 8;
        gpu_words.extend_from_slice(&words[at + 1..at + 4]);
        gpu_words.extend_from_slice(&words[at + 5..at + 8]);
        cpu_words.extend([p.x, p.y, p.z, n.x, n.y, n.z]);
    }
    assert!(
        words.chunks(8).all(|v| v[0] == blank && v[4] == blank),
        "{what}: a word outside the layout was written"
    );
    let what = format!("skinned vertices of {what}");
    let result = match agreement::policy() {
        Policy::Bits => check_bits(
            &what,
            bytemuck::cast_slice(&gpu_words),
            bytemuck::cast_slice(&cpu_words),
        ),
        Policy::Bounded => check_values(&what, &gpu_words, &cpu_words, &SKIN),
    };
    result.unwrap_or_else(|e| panic!("{e}"));
}
