//! The GPU semi-implicit integrator against the CPU f32 mirror, on lavapipe
//! in CI.

mod gpu_common;

use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::DVec3;
use wgcloth::model::{Corner, Pin};
use wgcloth::params::Integrator;
use wgcloth::{Model, Params};

fn scene(pins: Vec<Pin>) -> (Model, Params) {
    let params = busy_params(Integrator::SemiImplicit);
    (grid(17, 13, pins, &params), params)
}

/// As for the other integrators: the same f32 operations in the same order,
/// up to fused multiply-adds and rounding of division and square root.
const ONE_STEP_TOL: f64 = 1e-6;
/// 100 steps through the filter (a product over all particles), the
/// torque compensation's global sums and the fix-up: 1e-4 m.
const HUNDRED_STEP_TOL: f64 = 1e-4;

#[test]
fn semi_implicit_matches_the_cpu_mirror() {
    let pinned = vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)];
    // Without pins the torque compensation runs too.
    for pins in [pinned, vec![]] {
        let (model, params) = scene(pins.clone());
        for (steps, tol) in [(1, ONE_STEP_TOL), (100, HUNDRED_STEP_TOL)] {
            let (d, p, g, c) = compare(&model, &params, steps);
            eprintln!("{} pins, {steps} steps: worst {d:e} m", pins.len());
            assert!(
                d < tol,
                "{steps} steps: particle {p} GPU {g:?} CPU {c:?} differ by {d:e} m"
            );
        }
    }
}

/// The scalable filter is CG on the device (to relative tolerance 1e-5)
/// against the CPU's exact banded solve. One step moves each particle by
/// dt·Δv ≈ 5e-5 m under gravity; a 1e-5 relative error of that is 5e-10 m,
/// and f32 rounding of positions near 1 m is 6e-8 m: 1e-6 m covers both.
const SCALABLE_ONE_STEP_TOL: f64 = 1e-6;
/// Over 100 steps the per-step differences accumulate and feed back
/// through the springs and the fix-up: 1e-3 m.
const SCALABLE_HUNDRED_STEP_TOL: f64 = 1e-3;

#[test]
fn scalable_filter_matches_the_cpu_banded_filter() {
    let pinned = vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)];
    for pins in [pinned, vec![]] {
        let (model, mut params) = scene(pins.clone());
        params.semi_implicit.filter = wgcloth::params::FilterMethod::Banded;
        for (steps, tol) in [(1, SCALABLE_ONE_STEP_TOL), (100, SCALABLE_HUNDRED_STEP_TOL)] {
            let (d, p, g, c) = compare(&model, &params, steps);
            eprintln!(
                "scalable, {} pins, {steps} steps: worst {d:e} m",
                pins.len()
            );
            assert!(
                d < tol,
                "{steps} steps: particle {p} GPU {g:?} CPU {c:?} differ by {d:e} m"
            );
        }
    }
}

/// The constant filter's own test: after each step the device's `Δv`
/// (`W_DV`) solves `(M − dt² H) Δv = b` for the step's right-hand side `b`
/// (`W_RHS`) over the free particles, `H` the springs' constant Laplacian
/// (assembled here in `f64` from the mirror's springs, pins as fixed
/// rows): `‖b − A Δv‖ ≤ (tol + gap) ‖b‖` in the Jacobi norm CG stops in,
/// `tol` = [`wgcloth::gpu::FILTER_CG_TOLERANCE`], and pinned particles keep
/// `Δv = 0`. `gap` is [`agreement::RESIDUAL_GAP`]'s drift of CG's
/// recursive `f32` residual from the true one, 64 products' `U` rounding
/// times the size of what was summed relative to `b`, with that size
/// measured rather than bounded: `‖|b| + |A| |Δv|‖ / ‖b‖` (what the
/// condition number bounds there). On a grid (grid kernels, with the busy
/// scene's wind, ground and sphere) and a mesh (general kernels), both
/// pinned: colliders change the right-hand side (a spring touching one
/// keeps `k I` in `K v`), never the constant matrix.
#[test]
fn the_scalable_filter_solves_the_constant_system_to_its_tolerance() {
    use wgcloth::cpu::twins as cpu;
    use wgcloth::gpu::{DebugBuffer, GpuSolver, FILTER_CG_TOLERANCE};
    use wgcloth::kernel_config::work;
    use wgcloth::Scene;
    const STEPS: u32 = 30;
    let pinned = vec![Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)];
    let params = busy_params(Integrator::SemiImplicit);
    let mut banner = Scene::builtin("banner").expect("built in");
    banner.params.integrator = Integrator::SemiImplicit;
    let cloths = [
        ("33² grid", grid(33, 33, pinned, &params), params.clone()),
        ("banner mesh", banner.model().expect("valid"), banner.params),
    ];
    for (name, model, mut params) in cloths {
        params.semi_implicit.filter = wgcloth::params::FilterMethod::Banded;
        params.fixup.method = wgcloth::params::FixupMethod::Jacobi;
        let mut mirror = CpuSolver::<f64>::new(&model, &params).expect("valid");
        let (sys, _, _) = cpu::parts(&mut mirror);
        let n = sys.mass.len();
        let dt2 = sys.dt * sys.dt;
        let mut diag = sys.mass.clone();
        for sp in &sys.springs {
            diag[sp.i as usize] += dt2 * sp.k;
            diag[sp.j as usize] += dt2 * sp.k;
        }
        let mut g = GpuSolver::with_kernels(gpu().kernels(), &gpu().queue, &model, &params)
            .expect("GPU solver");
        let mut worst = 0.0f64;
        for step in 1..=STEPS {
            g.step(1).expect("GPU step");
            let words = g.debug_read(DebugBuffer::Work).expect("read-back");
            let at = |sec: u32, p: usize| -> DVec3 {
                let k = (sec as usize * n + p) * 4;
                let c = |i: usize| f64::from(f32::from_bits(words[k + i]));
                DVec3::new(c(0), c(1), c(2))
            };
            let dv: Vec<DVec3> = (0..n).map(|p| at(work::DV, p)).collect();
            let mut residual: Vec<DVec3> = (0..n)
                .map(|p| at(work::RHS, p) - dv[p] * sys.mass[p])
                .collect();
            let mut size: Vec<DVec3> = (0..n)
                .map(|p| at(work::RHS, p).abs() + dv[p].abs() * sys.mass[p])
                .collect();
            for sp in &sys.springs {
                let (i, j) = (sp.i as usize, sp.j as usize);
                let pull = (dv[i] - dv[j]) * (dt2 * sp.k);
                residual[i] -= pull;
                residual[j] += pull;
                let mag = (dv[i].abs() + dv[j].abs()) * (dt2 * sp.k);
                size[i] += mag;
                size[j] += mag;
            }

            let (mut r2, mut s2, mut b2) = (0.0, 0.0, 0.0);
            for p in 0..n {
                if sys.inv_mass[p] <= 0.0 {
                    assert_eq!(dv[p], DVec3::ZERO, "{name}: step {step}: pinned {p} moved");
                    continue;
                }
                r2 += residual[p].length_squared() / diag[p];
                s2 += size[p].length_squared() / diag[p];
                b2 += at(work::RHS, p).length_squared() / diag[p];
            }
            let relative = (r2 / b2).sqrt();
            let bound = FILTER_CG_TOLERANCE + 64.0 * agreement::U * (s2 / b2).sqrt();
            worst = worst.max(relative / bound);
            assert!(
                relative <= bound,
                "{name}: step {step}: relative residual {relative:e} over {bound:e}"
            );
        }
        eprintln!("{name}: the residual reached {worst:.2} of its bound over {STEPS} steps");
    }
}
