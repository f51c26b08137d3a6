//! `[material]`: a cloth in physical units. Conflicts and bad values are
//! refused naming the key; masses are the density times the lumped area;
//! the membrane's stiffness is the material's at every resolution and on
//! an irregular mesh (`docs/materials.md` derives the spring constants).

mod common;
mod gpu_common;

use std::path::{Path, PathBuf};

use common::{differing, irregular_sheet};
use wgcloth::evidence::sheet::textured_irregular_sheet;
use wgcloth::mesh::{Mesh, MeshCloth};
use wgcloth::model::Model;
use wgcloth::{CpuSolver, Scene, Vector};

/// Standard gravity \[m/s²\], as the scenes below write it.
const G: f64 = 9.81;
/// Density \[kg/m²\] and stretch stiffness \[N/m\] of the hanging sheets:
/// a strain `ρ g L / Y` of 1 % at the top of a 1 m sheet, small enough
/// for the linear theory the checks compare with.
const DENSITY: f64 = 0.3;
const STRETCH: f64 = 294.3;

fn load(text: &str) -> Result<Scene, String> {
    Scene::from_toml(text, Path::new("cloth.toml")).map_err(|e| e.to_string())
}

fn refusal(text: &str) -> String {
    match load(text) {
        Ok(_) => panic!("should be refused:\n{text}"),
        Err(e) => e,
    }
}

#[test]
fn material_beside_a_mass_or_a_spring_table_is_refused_naming_both() {
    for (extra, key) in [
        ("[cloth]\nmass = 1.0\n", "`cloth.mass`"),
        (
            "[springs.stretch]\nstiffness = 10.0\n",
            "`[springs.stretch]`",
        ),
        ("[springs.shear]\ndamping = 0.0\n", "`[springs.shear]`"),
        ("[springs.bend]\nstiffness = 0.0\n", "`[springs.bend]`"),
    ] {
        let e = refusal(&format!("[material]\ndensity = 0.2\n{extra}"));
        assert!(
            e.contains("cloth.toml")
                && e.contains(key)
                && e.contains("conflicts with `[material]`"),
            "{e}"
        );
    }
}

#[test]
fn material_values_out_of_range_are_refused_naming_the_key() {
    for (line, key, says) in [
        ("density = 0.0", "material.density", "> 0 (kg/m²)"),
        ("density = -1.0", "material.density", "> 0 (kg/m²)"),
        ("density = nan", "material.density", "finite"),
        ("stretch = inf", "material.stretch", "finite"),
        ("stretch = 0.0", "material.stretch", "0 < stiffness"),
        ("shear = -2.0", "material.shear", "0 < stiffness"),
        ("shear = 2e6", "material.shear", "≤ 1e6"),
        ("damping = -1e-3", "material.damping", "0 ≤ damping ≤ 1"),
        ("bending = -1.0", "material.bending", "0 ≤ bending ≤ 1"),
        ("bending = 2.0", "material.bending", "0 ≤ bending ≤ 1"),
        (
            "stretch = { warp = 50.0, weft = 0.0 }",
            "material.stretch.weft",
            "0 < stiffness",
        ),
        (
            "bending = { warp = 1e-3, weft = 0.0 }",
            "material.bending",
            "along both the warp and the weft",
        ),
        (
            "stretch = { warp = 50.0 }",
            "material.stretch",
            "missing key `weft`",
        ),
        (
            "bending = { warp = 1e-3, weft = 1e-4, bias = 1e-4 }",
            "material.bending",
            "unknown key `bias`",
        ),
        (
            "bending = \"stiff\"",
            "material.bending",
            "{ warp = …, weft = … }",
        ),
        ("colour = 1.0", "material.colour", "unknown key"),
    ] {
        let e = refusal(&format!("[material]\n{line}\n"));
        assert!(
            e.contains("cloth.toml") && e.contains(key) && e.contains(says),
            "{line}: {e}"
        );
    }
    // Cells ten times longer than wide cannot have shear springs as stiff
    // as the stretch ones: a side would get a negative stiffness.
    let e = refusal(
        "[cloth]\nresolution = [3, 21]\nsize = [1.0, 0.1]\n\
         [material]\nstretch = 100.0\nshear = 100.0\n",
    );
    assert!(e.contains("material.shear") && e.contains("r = 10"), "{e}");
}

#[test]
fn without_a_material_the_springs_take_their_kinds_constants() {
    let scene = load("[cloth]\nresolution = [5, 5]\n").expect("loads");
    assert_eq!(scene.cloths[0].material, None);
    let model = scene.model().expect("builds");
    assert!(model.own_constants.is_empty());
    let default = wgcloth::Params::default();
    for (s, sp) in model.springs.iter().enumerate() {
        let c = model.spring_constants(s, &scene.params);
        assert_eq!(c.k, default.spring(sp.kind).stiffness);
        assert_eq!(c.kd, default.spring(sp.kind).damping);
    }
}

/// Relative tolerance of sums of masses: a few hundred `f64` additions.
const MASS_SUM_TOLERANCE: f64 = 1e-12;

fn close(a: f64, b: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance * b.abs()
}

#[test]
fn a_grid_particle_weighs_the_density_times_a_third_of_its_triangles_area() {
    let (nx, ny, w, h) = (17usize, 9usize, 1.0, 0.5);
    let scene = load(&format!(
        "[cloth]\nresolution = [{nx}, {ny}]\nsize = [{w}, {h}]\n\
         [material]\ndensity = {DENSITY}\n"
    ))
    .expect("loads");
    let model = scene.model().expect("builds");
    let cell = DENSITY * (w / (nx - 1) as f64) * (h / (ny - 1) as f64);
    let total: f64 = model.mass.iter().sum();
    assert!(close(total, DENSITY * w * h, MASS_SUM_TOLERANCE), "{total}");
    assert!(close(scene.cloths[0].spec.mass, total, MASS_SUM_TOLERANCE));
    for row in 0..ny {
        for col in 0..nx {
            let (inner_r, inner_c) = (row > 0 && row < ny - 1, col > 0 && col < nx - 1);
            // Six triangles around an inner particle (a cell's worth),
            // three along a side, and one or two at a corner, by the
            // diagonal each cell is split along.
            let expected = match (inner_r, inner_c) {
                (true, true) => cell,
                (true, false) | (false, true) => cell / 2.0,
                _ if (row == 0) == (col == 0) => cell / 6.0,
                _ => cell / 3.0,
            };
            let m = model.mass[row * nx + col];
            assert!(
                close(m, expected, 1e-12),
                "({row}, {col}): {m} vs {expected}"
            );
        }
    }
}

/// A hanging sheet of `[material]` with the top edge pinned: a grid of
/// `nx × ny` particles or (`mesh_rows = Some`) the irregular mesh in
/// place of that grid.
fn hanging(width: f64, grid: [usize; 2], mesh_rows: Option<usize>, shear: f64) -> (Scene, Model) {
    hanging_woven(width, grid, mesh_rows, shear, &STRETCH.to_string(), "0")
}

/// [`hanging`] of a fabric whose `stretch` and `bending` are written as
/// the scene file gives them (one number, or per direction).
fn hanging_woven(
    width: f64,
    grid: [usize; 2],
    mesh_rows: Option<usize>,
    shear: f64,
    stretch: &str,
    bending: &str,
) -> (Scene, Model) {
    let text = format!(
        "[simulation]\nintegrator = \"implicit\"\ndt = {SETTLE_DT}\ngravity = [0.0, -{G}, 0.0]\n\
         [implicit]\ntolerance = {CG_TOLERANCE}\nmax_iterations = 2000\n\
         [cloth]\nresolution = [{}, {}]\nsize = [{width}, 1.0]\norigin = [0.0, 0.0, 0.0]\n\
         orientation = \"vertical\"\npins = [\"top\"]\n\
         [material]\ndensity = {DENSITY}\nstretch = {stretch}\nshear = {shear}\n\
         bending = {bending}\ndamping = {DAMPING}\n",
        grid[0], grid[1]
    );
    let mut scene = load(&text).expect("loads");
    if let Some(rows) = mesh_rows {
        // Texture coordinates from the positions: the warp along x.
        let obj = textured_irregular_sheet(width, rows, |[x, y]| ([x, y, 0.0], [x, y]));
        let mesh = Mesh::parse(obj.as_bytes(), Path::new("sheet.obj"), None, &|_| {
            Err("no external files".to_string())
        })
        .expect("a valid mesh");
        scene.cloths[0].mesh = Some(MeshCloth {
            path: PathBuf::from("sheet.obj"),
            mesh_name: None,
            scale: 1.0,
            mesh,
        });
        scene.cloths[0].spec.pins = vec![wgcloth::model::Pin::Region([
            wgcloth::glam::DVec3::new(-1.0, -1e-9, -1.0),
            wgcloth::glam::DVec3::new(2.0, 1e-9, 1.0),
        ])];
    }
    let model = scene.model().expect("builds");
    (scene, model)
}

/// Time step of the settling runs \[s\]: backward Euler damps the sheet's
/// slowest stretch mode (≈ 50 rad/s) by ~10 % a step.
const SETTLE_DT: f64 = 0.01;
/// Relative CG tolerance: the positions at rest to ~1e-9 of the sag.
const CG_TOLERANCE: f64 = 1e-9;
/// Rayleigh time constant \[s\]: damps the fastest modes within a few steps.
const DAMPING: f64 = 0.01;
/// A sheet is at rest when no particle moves faster \[m/s\]: with its
/// slowest modes' ≳ 5 rad/s, within ~2e-7 m (1e-4 of the sags measured)
/// of its rest shape.
const REST_SPEED: f64 = 1e-6;

/// The rest state of `model` under `params`.
fn settle(scene: &Scene, model: &Model) -> Vec<[f64; 3]> {
    let mut solver = CpuSolver::<f64>::new(model, &scene.params).expect("a solver");
    for _ in 0..40 {
        solver.step_n(50).expect("steps");
        let fastest = solver
            .velocities()
            .iter()
            .map(|v| {
                let [x, y, z] = v.to_f64();
                (x * x + y * y + z * z).sqrt()
            })
            .fold(0.0, f64::max);
        if fastest < REST_SPEED {
            return solver.positions().iter().map(|p| p.to_f64()).collect();
        }
    }
    panic!("the sheet did not come to rest in 2000 steps");
}

/// The mean drop \[m\] of the particles whose rest height is `y`.
fn mean_drop(model: &Model, x: &[[f64; 3]], y: f64) -> f64 {
    let row: Vec<usize> = (0..model.particle_count())
        .filter(|&p| (model.rest_positions[p].y - y).abs() < 1e-12)
        .collect();
    assert!(!row.is_empty(), "no particle at rest height {y}");
    row.iter()
        .map(|&p| model.rest_positions[p].y - x[p][1])
        .sum::<f64>()
        / row.len() as f64
}

/// The stretch stiffness \[N/m\] a hanging strip shows between its middle
/// and its bottom edge, where the tension per unit width at depth `s` is
/// `ρ g (1 − s)` and the strip is free to narrow: that half stretches by
/// `ρ g (1 − ½)² / (2Y)`.
fn strip_stiffness(model: &Model, x: &[[f64; 3]]) -> f64 {
    let stretch = mean_drop(model, x, -1.0) - mean_drop(model, x, -0.5);
    DENSITY * G * 0.125 / stretch
}

/// How close a strip's stiffness comes to `stretch`: the top edge's pins
/// keep the strip from narrowing there, which fades within about a width
/// (e^(−2π) ≈ 0.2 % at the middle of a strip four times longer than wide)
/// and the mass lumped at the rows is exact for the linear tension.
const GRID_STIFFNESS_TOLERANCE: f64 = 0.01;
/// The irregular mesh's triangles (65 rows) are only nearly equilateral,
/// for which alone Van Gelder's springs have the stiffness `stretch`
/// exactly; those along the strip's sides, cut by its edges, least.
const MESH_STIFFNESS_TOLERANCE: f64 = 0.03;

#[test]
fn a_strip_pulled_along_its_length_has_the_stretch_stiffness() {
    // Shear stiffness 3/8 of the stretch (an isotropic grid) and a tenth
    // of it: the uniaxial stiffness is the stretch either way.
    for shear in [STRETCH * 3.0 / 8.0, STRETCH / 10.0] {
        let (scene, model) = hanging(0.25, [9, 33], None, shear);
        let y = strip_stiffness(&model, &settle(&scene, &model));
        println!("grid 9 × 33, shear {shear}: {y:.3} N/m");
        assert!(
            close(y, STRETCH, GRID_STIFFNESS_TOLERANCE),
            "shear {shear}: {y}"
        );
    }
    // On the mesh the triangles along the strip's sides are far from
    // equilateral; their share of the width, and so the deviation, falls
    // with resolution.
    let mut previous = f64::INFINITY;
    for rows in [33, 65] {
        let grid = [(rows - 1) / 4 + 1, rows];
        let (scene, model) = hanging(0.25, grid, Some(rows), STRETCH * 3.0 / 8.0);
        let y = strip_stiffness(&model, &settle(&scene, &model));
        let d = (y - STRETCH) / STRETCH;
        println!("irregular mesh, {rows} rows: {y:.3} N/m ({d:+.4})");
        assert!(d.abs() < previous, "{rows} rows: {d} does not fall");
        previous = d.abs();
    }
    assert!(previous < MESH_STIFFNESS_TOLERANCE, "{previous}");
}

/// A hanging grid stretches along its weft (its columns run down): pulled
/// so, a strip of a fabric given a stretch per direction has the weft's,
/// whatever the warp's is, within the grid's own tolerance.
#[test]
fn a_strip_pulled_along_the_weft_has_the_wefts_stretch_stiffness() {
    for warp in [STRETCH * 4.0, STRETCH / 3.0] {
        let stretch = format!("{{ warp = {warp}, weft = {STRETCH} }}");
        let (scene, model) = hanging_woven(0.25, [9, 33], None, STRETCH / 10.0, &stretch, "0");
        let y = strip_stiffness(&model, &settle(&scene, &model));
        println!("warp {warp}, weft {STRETCH}: {y:.3} N/m");
        assert!(
            close(y, STRETCH, GRID_STIFFNESS_TOLERANCE),
            "warp {warp}: {y}"
        );
    }
}

#[test]
fn a_mesh_particle_weighs_the_density_times_a_third_of_its_triangles_area() {
    let (scene, model) = hanging(1.0, [17, 17], Some(17), STRETCH * 3.0 / 8.0);
    let (_, triangles) = irregular_sheet(1.0, 17);
    let mut expected = vec![0.0; model.particle_count()];
    for t in &triangles {
        let [a, b, c] = t.map(|p| model.rest_positions[p]);
        let area = 0.5 * ((b - a).x * (c - a).y - (b - a).y * (c - a).x);
        assert!(area > 0.0, "the test's mesh is counter-clockwise");
        for &p in t {
            expected[p] += DENSITY * area / 3.0;
        }
    }
    for (p, (&m, &e)) in model.mass.iter().zip(&expected).enumerate() {
        assert!(close(m, e, 1e-12), "particle {p}: {m} vs {e}");
    }
    let total: f64 = model.mass.iter().sum();
    assert!(close(total, DENSITY, MASS_SUM_TOLERANCE), "{total}");
    assert!(scene.cloths[0].material.is_some());
}

/// How far the bottom edge's sag at 17² and 33² and on the irregular mesh
/// may lie from the 65² one, relative: the sag's discretisation error
/// near the pinned corners, where the stress is singular.
const SAG_TOLERANCE: f64 = 0.02;

#[test]
fn a_hanging_sheet_sags_alike_at_every_resolution_and_on_a_mesh() {
    // Shear 3/8 of the stretch: the grid is isotropic with Poisson's ratio
    // 1/3, as an equilateral triangle lattice is.
    let shear = STRETCH * 3.0 / 8.0;
    let sag = |grid: usize, mesh: Option<usize>| {
        let (scene, model) = hanging(1.0, [grid, grid], mesh, shear);
        mean_drop(&model, &settle(&scene, &model), -1.0)
    };
    let fine = sag(65, None);
    let one_dimensional = DENSITY * G / (2.0 * STRETCH);
    println!("65²: sag {fine:.6e} m (a strip free to narrow: {one_dimensional:.6e} m)");
    let mut previous = f64::INFINITY;
    for n in [17, 33] {
        let d = (sag(n, None) - fine) / fine;
        println!("{n}²: {d:+.4} from 65²");
        assert!(d.abs() < SAG_TOLERANCE, "{n}²: {d}");
        assert!(
            d.abs() < previous,
            "{n}²: {d} does not fall with resolution"
        );
        previous = d.abs();
    }
    let d = (sag(33, Some(33)) - fine) / fine;
    println!("irregular mesh, 33 rows: {d:+.4} from 65²");
    assert!(d.abs() < SAG_TOLERANCE, "mesh: {d}");
}

/// Steps of the GPU comparison: enough for the wind to fold the sheet out
/// of its plane and the fix-up and CG to act every step.
const GPU_STEPS: u32 = 60;

/// A sheet of a material, on a grid of oblong cells (so its two stretch
/// directions differ) and on the irregular mesh, blown out of its plane:
/// the GPU on both step paths and every integrator gives the `f32`
/// mirror's positions bit for bit (under the bounded policy, each step
/// within its bound of the mirror re-seeded before it); a grid of a material, whose springs
/// have constants of their own, runs the general kernels (a per-spring
/// force pass).
#[test]
fn the_gpu_runs_a_material_as_the_f32_mirror_bit_for_bit() {
    use wgcloth::gpu::{GpuSolver, Kernel, StepPath};
    use wgcloth::params::{FixupMethod, Integrator, Wind};
    let ctx = match wgcloth::GpuContext::new(None) {
        Ok(c) => c,
        Err(e) => panic!("this test needs an adapter (lavapipe works): {e}"),
    };
    let woven = format!("{{ warp = {}, weft = {STRETCH} }}", STRETCH / 3.0);
    let iso = STRETCH.to_string();
    // The explicit integrator at 1 ms cannot step this soft sheet's
    // bending (Gershgorin's bound refuses it), so only the others bend.
    let bent = "{ warp = 1e-5, weft = 2.5e-6 }";
    for (what, grid, mesh, stretch, bending) in [
        ("grid", [13, 9], None, &iso, "0"),
        ("mesh", [9, 9], Some(9), &iso, "0"),
        ("woven grid", [13, 9], None, &woven, "0"),
        ("woven mesh", [9, 9], Some(9), &woven, "0"),
        ("woven bent grid", [13, 9], None, &woven, bent),
    ] {
        let (mut scene, model) = hanging_woven(1.0, grid, mesh, STRETCH / 4.0, stretch, bending);
        let params = &mut scene.params;
        params.fixup.method = FixupMethod::Jacobi;
        params.implicit.tolerance = 1e-4;
        params.implicit.max_iterations = 40;
        params.wind = Some(Wind {
            velocity: wgcloth::glam::DVec3::new(0.0, 0.0, 4.0),
            drag: 0.6,
            lift: 0.1,
        });
        for integrator in Integrator::ALL {
            if bending != "0" && integrator == Integrator::Explicit {
                continue;
            }
            let params = wgcloth::Params {
                integrator,
                dt: if integrator == Integrator::Explicit {
                    1e-3
                } else {
                    1.0 / 120.0
                },
                ..scene.params.clone()
            };
            let mut cpu = CpuSolver::<f32>::new(&model, &params).expect("CPU solver");
            cpu.step_n(u64::from(GPU_STEPS)).expect("CPU run");
            let mirror = cpu.positions();
            let moved = mirror.iter().map(|x| x.z.abs()).fold(0.0f32, f32::max);
            assert!(
                moved > 1e-3,
                "{what} {integrator}: the wind moved it {moved} m"
            );
            for path in [StepPath::MultiDispatch, StepPath::Workgroup] {
                let mut g =
                    GpuSolver::with_step_path(ctx.kernels(), &ctx.queue, &model, &params, path)
                        .unwrap_or_else(|e| panic!("{what} {integrator} on {path}: {e}"));
                g.tuning_mut().set_adaptive_cg_budget(false);
                if integrator == Integrator::Explicit && path == StepPath::MultiDispatch {
                    let plan = g.tuning().step_plan();
                    assert!(
                        plan.iter().any(|d| d.kernel == Kernel::SpringForces),
                        "{what}: {plan:?}"
                    );
                }
                let at = format!("{what} {integrator} on {path}");
                let bounded = gpu_common::bounded_steps(&at, || &mut g, &model, &params, GPU_STEPS);
                if let Some(verdict) = bounded {
                    verdict.unwrap_or_else(|e| panic!("{e}"));
                    continue;
                }
                g.step(GPU_STEPS).expect("GPU run");
                let x = g.read_state().expect("read-back").x;
                let (n, p) = differing(&x, &mirror);
                assert_eq!(
                    n, 0,
                    "{what} {integrator} on {path}: {n} positions differ from the f32 \
                     mirror's, the first particle {p:?}"
                );
            }
        }
    }
}
