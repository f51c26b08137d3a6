//! The linear bending model (`[material] bending`, `src/bending.rs`): the
//! energy it stores, the cantilever and overhang it reproduces, and what it
//! refuses.

mod common;

use std::path::Path;

use common::irregular_sheet;
use wgcloth::bending::Bending;
use wgcloth::evidence::cantilever::{overhang, settle_material, MATERIAL_ROWS};
use wgcloth::evidence::elastica;
use wgcloth::glam::DVec3;
use wgcloth::params::Integrator;
use wgcloth::{CpuSolver, Scene};

fn load(text: &str) -> Result<Scene, String> {
    Scene::from_toml(text, Path::new("cloth.toml")).map_err(|e| e.to_string())
}

/// A flat `size × size` grid of `n × n` particles in the xz-plane.
fn grid(n: usize, size: f64) -> (Vec<DVec3>, Bending) {
    let h = size / (n - 1) as f64;
    let x = (0..n)
        .flat_map(|r| (0..n).map(move |c| DVec3::new(c as f64 * h, 0.0, r as f64 * h)))
        .collect();
    (
        x,
        Bending::grid(n, n, h, h, 1.0, 0.0, &[]).expect("grid operator"),
    )
}

/// The irregular mesh of the unit square (`rows` rows of vertices), laid
/// in the xz-plane, and Bergou's operator on it.
fn mesh(rows: usize) -> (Vec<DVec3>, Bending) {
    let (obj, triangles) = irregular_sheet(1.0, rows);
    let x: Vec<DVec3> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l.split(' ').map(|s| s.parse().expect("a number")).collect();
            DVec3::new(v[0], 0.0, -v[1])
        })
        .collect();
    let triangles: Vec<[u32; 3]> = triangles.iter().map(|t| t.map(|p| p as u32)).collect();
    let b = Bending::new(&x, &triangles, 1.0, &[], 0.0, &[]).expect("mesh operator");
    (x, b)
}

/// `x` wrapped onto a cylinder of curvature `kappa` \[1/m\] whose axis lies
/// in the sheet's plane at `angle` \[rad\] from the z axis: a bend without
/// stretch (an isometry).
fn cylinder(x: &[DVec3], kappa: f64, angle: f64) -> Vec<DVec3> {
    let (s, c) = angle.sin_cos();
    let across = DVec3::new(c, 0.0, -s);
    let along = DVec3::new(s, 0.0, c);
    let r = 1.0 / kappa;
    x.iter()
        .map(|p| {
            let (u, w) = (p.dot(across), p.dot(along));
            across * (r * (u / r).sin()) + along * w + DVec3::Y * (r * (1.0 - (u / r).cos()))
        })
        .collect()
}

/// What a flat sheet's operator leaves of `Q x` at rest: `f64` rounding of
/// sums of a dozen terms of size `B/h²` (≤ 1e4 here) about positions ~1 m.
const FLAT_FORCE: f64 = 1e-9;

#[test]
fn a_flat_sheet_has_no_bending_force_on_grids_and_meshes() {
    for (what, (x, b)) in [("grid", grid(17, 1.0)), ("mesh", mesh(13))] {
        for p in 0..x.len() {
            let f = b.apply_row(&x, p);
            assert!(f.length() < FLAT_FORCE, "{what}: particle {p}: {f}");
        }
        assert!(b.energy(&x).abs() < FLAT_FORCE, "{what}");
        // Moved rigidly, it still stores nothing.
        let q = wgcloth::glam::DQuat::from_rotation_x(0.7);
        let moved: Vec<DVec3> = x.iter().map(|p| q * *p + DVec3::ONE).collect();
        assert!(b.energy(&moved).abs() < FLAT_FORCE, "{what}: rigid motion");
    }
}

/// How far the grid's cylinder energy may fall below `½ B κ² A`: the end
/// particles of each row carry no second difference, so a strip `h/2`
/// wide at either end stores nothing — a share `h / L` of the area, and
/// a little more across a diagonal, where every row is short. `1.5 h` over
/// a 1 m sheet.
fn grid_shortfall(n: usize) -> f64 {
    1.5 / (n - 1) as f64
}

/// The irregular mesh's deviation from `½ B κ² A` (Bergou's operator on
/// near-equilateral triangles jittered by a tenth of a side): its
/// boundary edges carry no hinge, so a bend across its rows loses the
/// ends' share. Measured: −8.4 % (across) and +1.1 % (along) at 13 rows,
/// −4.2 % and +0.25 % at 25; the bound is the coarse mesh's with a margin.
const MESH_ENERGY_TOLERANCE: f64 = 0.12;

#[test]
fn a_sheet_bent_into_a_cylinder_stores_half_b_kappa_squared_per_area() {
    let kappa = 0.8;
    let exact = 0.5 * kappa * kappa; // B = 1 N·m, A = 1 m²
    let mut previous = f64::INFINITY;
    for n in [17, 33, 65] {
        let (x, b) = grid(n, 1.0);
        let mut worst: f64 = 0.0;
        for angle in [
            0.0,
            0.3,
            std::f64::consts::FRAC_PI_4,
            std::f64::consts::FRAC_PI_2,
        ] {
            let ratio = b.energy(&cylinder(&x, kappa, angle)) / exact;
            assert!(
                ratio <= 1.0 + 1e-3 && ratio >= 1.0 - grid_shortfall(n),
                "grid {n}²: axis at {angle} rad: {ratio}"
            );
            worst = worst.max(1.0 - ratio);
        }
        assert!(worst < previous, "grid {n}²: {worst} does not fall");
        previous = worst;
    }
    for rows in [13, 25] {
        let (x, b) = mesh(rows);
        for angle in [0.0, std::f64::consts::FRAC_PI_2] {
            let ratio = b.energy(&cylinder(&x, kappa, angle)) / exact;
            assert!(
                (ratio - 1.0).abs() < MESH_ENERGY_TOLERANCE,
                "mesh of {rows} rows: axis at {angle} rad: {ratio}"
            );
        }
    }
}

/// How far the settled tip's drop may lie from the heavy elastica's,
/// relative, for a strip clamped as a user clamps it (every particle at
/// `x ≤ 0` pinned) at 16 segments and above over `Γ = 10⁻² … 10²`: the
/// issue's 2 %. Measured: 0.39 % at small `Γ` and 0.73 % at `Γ = 100` at
/// 16 segments, a quarter of that at 32. The clamp half a cell behind the
/// pins (`bending::CLAMP_WEIGHT` 1, tried) is 12.9 % off at 16 segments.
const CLAMPED_DROP_TOLERANCE: f64 = 0.02;

/// How far `H/W` (tip drop over reach) may lie from the elastica's at 32
/// segments: 1.1 % measured at `Γ = 100`, where the strip turns down
/// within a tenth of its length of the clamp and the reach, a small
/// number, carries the error (4.1 % at 16 segments, 18 % at 8).
const CLAMPED_SHAPE_TOLERANCE: f64 = 0.02;

/// How far the same strip's drop at 15 and at 30 segments may differ,
/// relative: the 1 %. Measured 0.60 % at `Γ = 100`, 0.33 % at
/// `Γ = 1`; the issue measured 6.5 % with the clamp half a cell behind the
/// pins.
const RESOLUTION_AGREEMENT: f64 = 0.01;

/// The least order of convergence of the drop at the clamp, from 8 to 16
/// segments at `Γ = 1`: 1.99 measured (the deviation falls 3.98× per
/// halving); the clamp half a cell behind the pins converges at first
/// order (1.04, tried).
const CLAMP_ORDER: f64 = 1.8;

/// The tip drop of a strip of `segments` at `gamma` over the elastica's,
/// less one.
fn drop_deviation(segments: usize, gamma: f64) -> f64 {
    let run =
        settle_material(segments, MATERIAL_ROWS, gamma, Integrator::Implicit).expect("settles");
    assert!(run.settled, "{segments} segments, Γ = {gamma}: {run:?}");
    let tip = elastica::tip(gamma).expect("elastica");
    run.drop / tip.drop - 1.0
}

#[test]
fn a_material_cantilever_clamped_where_it_stands_follows_the_elastica() {
    for gamma in [0.01, 0.1, 1.0, 10.0, 100.0] {
        let d = drop_deviation(16, gamma);
        assert!(
            d.abs() < CLAMPED_DROP_TOLERANCE,
            "16 segments, Γ = {gamma}: the drop deviates by {d}"
        );
    }
    for gamma in [1.0, 100.0] {
        let run = settle_material(32, MATERIAL_ROWS, gamma, Integrator::Implicit).expect("settles");
        let tip = elastica::tip(gamma).expect("elastica");
        let drop = run.drop / tip.drop - 1.0;
        let shape = (run.drop / run.reach) / (tip.drop / tip.reach) - 1.0;
        assert!(
            drop.abs() < CLAMPED_DROP_TOLERANCE && shape.abs() < CLAMPED_SHAPE_TOLERANCE,
            "32 segments, Γ = {gamma}: the drop deviates by {drop}, H/W by {shape}"
        );
    }
}

#[test]
fn a_material_cantilever_converges_at_second_order_at_the_clamp() {
    let (coarse, fine) = (drop_deviation(8, 1.0), drop_deviation(16, 1.0));
    let order = (coarse / fine).abs().log2();
    assert!(
        order >= CLAMP_ORDER,
        "order {order} (deviation {coarse} at 8 segments, {fine} at 16)"
    );
    for gamma in [1.0, 100.0] {
        let drop = |segments| {
            settle_material(segments, MATERIAL_ROWS, gamma, Integrator::Implicit)
                .expect("settles")
                .drop
        };
        let (a, b) = (drop(15), drop(30));
        assert!(
            (a - b).abs() / b < RESOLUTION_AGREEMENT,
            "Γ = {gamma}: drop {a} at 15 segments, {b} at 30"
        );
    }
}

/// How far the rigidity ASTM D1388's overhang implies may lie from the
/// material's: the 2 % at 16 segments (0.69 % measured, the strip
/// clamped where the table ends; −13.1 % with the clamp half a cell behind
/// the pins, tried).
const OVERHANG_TOLERANCE: f64 = 0.02;

/// Steps of the stiff-bending runs (1 s at 1/60 s).
const STIFF_STEPS: u64 = 60;

#[test]
fn stiff_bending_is_stable_implicitly_and_holds_a_sheet_up() {
    // A 17² sheet clamped along one edge (its first two columns pinned),
    // bending 0.05 N·m: at dt = 1/60 s
    // its stiffest bending vibration has dt ω near 60, so an integrator
    // that stepped the bending force explicitly would blow up at once;
    // the implicit integrator has it in its system matrix and the
    // semi-implicit one in Desbrun's constant filter. The sheet (Γ ≈ 5 as
    // a cantilever) must also stay higher on average than without
    // bending, which lets it fall and swing below its pins.
    let text = |integrator: &str, bending: f64| {
        format!(
            "[simulation]\nintegrator = \"{integrator}\"\ndt = {}\n\
             [cloth]\nresolution = [17, 17]\nsize = [0.5, 0.5]\norigin = [0.0, 1.0, 0.0]\n\
             pins = [{{ box = [[-0.01, 0.9, -0.1], [0.04, 1.1, 0.6]] }}]\n[material]\ndensity = 0.2\nstretch = 500.0\nshear = 100.0\n\
             bending = {bending}\ndamping = 0.01\n",
            1.0 / 60.0
        )
    };
    for integrator in ["implicit", "semi-implicit"] {
        let mean_height = |bending: f64| {
            let scene = load(&text(integrator, bending)).expect("loads");
            let model = scene.model().expect("builds");
            let bound = model
                .bending
                .as_ref()
                .map(|b| b.omega_squared_bound(&model.mass, &model.pinned).sqrt() / 60.0);
            let mut solver = CpuSolver::<f64>::new(&model, &scene.params).expect("solver");
            solver.step_n(STIFF_STEPS).expect("stays finite");
            let x = solver.positions();
            let y = x.iter().map(|p| p.y).sum::<f64>() / x.len() as f64;
            (y, bound)
        };
        let (stiff, bound) = mean_height(0.05);
        let (limp, _) = mean_height(0.0);
        assert!(
            bound.is_some_and(|b| b > 10.0),
            "{integrator}: dt ω ≤ {bound:?}"
        );
        assert!(
            stiff.is_finite() && stiff > limp,
            "{integrator}: {stiff} against {limp}"
        );
    }
}

#[test]
fn the_overhang_test_recovers_the_bending_stiffness() {
    // A cotton shirting: 0.12 kg/m², 5 µN·m.
    let o = overhang(0.12, 5e-6, 16).expect("overhang");
    assert!(o.deviation.abs() < OVERHANG_TOLERANCE, "{o:?}");
    assert!((o.gamma - 8.0).abs() < 0.1, "{o:?}");
}

#[test]
fn bending_refusals_name_the_key_and_what_is_allowed() {
    // Too stiff for the explicit integrator at its step.
    let e = load(
        "[simulation]\nintegrator = \"explicit\"\ndt = 0.01\n\
         [cloth]\nresolution = [17, 17]\n[material]\nbending = 0.5\n",
    )
    .and_then(|s| s.model().map_err(|e| e.to_string()))
    .expect_err("refused");
    assert!(
        e.contains("material.bending") && e.contains("explicit integrator"),
        "{e}"
    );
    // The same sheet is fine implicitly.
    let scene = load(
        "[simulation]\nintegrator = \"implicit\"\ndt = 0.01\n\
         [cloth]\nresolution = [17, 17]\n[material]\nbending = 0.5\n",
    )
    .expect("loads");
    let model = scene.model().expect("builds");
    assert!(model.bending.is_some());
    // A curved rest shape has no flat state to measure bending from.
    let mut x = mesh(9).0;
    x[40].y += 0.05;
    let (_, triangles) = irregular_sheet(1.0, 9);
    let triangles: Vec<[u32; 3]> = triangles.iter().map(|t| t.map(|p| p as u32)).collect();
    let e = Bending::new(&x, &triangles, 1e-3, &[], 0.0, &[]).expect_err("refused");
    assert!(
        e.to_string().contains("material.bending") && e.to_string().contains("flat"),
        "{e}"
    );
}
