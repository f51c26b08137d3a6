//! Self-collision's triangle method (`[self_collision] method =
//! "triangles"`, `src/cpu/triangle_contact.rs`) on the CPU solvers, `f64`
//! and `f32`, every integrator: a metre of 33² cloth folded in three
//! layers at a thickness of 2 mm (a fifteenth of its spacing) falls and
//! lands with no edge through a triangle at any step, where without
//! self-collision its layers pass through one another; a fold slammed shut
//! at 5 m/s crosses nothing; a hanging sheet, a thrown sheet and a stack
//! of two falling whole move bit for bit as without it; a sheet thrown
//! along another slides several bounds a step; thicknesses out of range,
//! and the GPU, are refused naming the key.

mod common;

use std::collections::HashMap;

use common::edges;
use wgcloth::cpu::{CpuSolver, State};
use wgcloth::glam::DVec3;
use wgcloth::model::{ClothSpec, Model, Orientation};
use wgcloth::params::{ContactMethod, Ground, Integrator, Params, SelfCollision, SpringKind};
use wgcloth::real::Vec3;
use wgcloth::self_collision::{self, BOUND_FRACTION};
use wgcloth::{Error, Real};

/// The thickness \[m\].
const THICKNESS: f64 = 0.002;
/// Particles along each side of the metre of cloth.
const N: usize = 33;
/// Layers of the fold, and rows of the cloth in each.
const LAYERS: usize = 3;
const LAYER_ROWS: usize = N / LAYERS;
/// The rest spacing \[m\].
const SPACING: f64 = 1.0 / (N - 1) as f64;

/// No vertex comes nearer a triangle it is not a corner of than this
/// fraction of the thickness (the bound). A pair within the
/// thickness is pushed back to it by its passes; what is left is the
/// approach of the last pass's neighbours (Jacobi: each pass sees the
/// others' positions before it) and a vertex's pushes being averaged over
/// its contacts, a few tenths of a thickness at most where layers land on
/// one another at the drop's speeds.
const MIN_GAP: f64 = 0.5;

/// Where two layers rest on one another, their vertices lie within this
/// many thicknesses of the other layer (the bound: they touch, and
/// do not float on a cushion of the method's making): the median over the
/// upper layers' inner vertices that have another layer within
/// `LANDED` thicknesses.
const RESTING_GAP: f64 = 3.0;

/// How near another layer \[thicknesses\] a vertex counts as landed on
/// it: five of the resting bound, so a layer floating short of landing
/// still counts, and shows in the median.
const LANDED: f64 = 5.0 * RESTING_GAP;

/// A metre of `N × rows` cloth (rest flat), `params`' springs.
fn model(rows: usize, params: &Params) -> Model {
    let spec = ClothSpec {
        nx: N,
        ny: rows,
        size: [1.0, SPACING * (rows - 1) as f64],
        origin: DVec3::ZERO,
        orientation: Orientation::Horizontal,
        mass: 0.3,
        pins: vec![],
    };
    Model::new(&spec, &params.springs).expect("valid cloth")
}

/// The cloth folded in a Z of `layers` layers of `LAYER_ROWS` rows, `gap`
/// \[m\] between layers (each fold a stretch spring standing vertical),
/// the lowest `height` above the ground.
fn folded(layers: usize, gap: f64, height: f64) -> Vec<DVec3> {
    (0..N * layers * LAYER_ROWS)
        .map(|p| {
            let (i, j) = (p % N, p / N);
            let (layer, s) = (j / LAYER_ROWS, j % LAYER_ROWS);
            let along = if layer % 2 == 0 {
                s
            } else {
                LAYER_ROWS - 1 - s
            };
            DVec3::new(
                i as f64 * SPACING,
                height + layer as f64 * gap,
                along as f64 * SPACING,
            )
        })
        .collect()
}

/// The bend springs' stiffness \[N/m\]: a tenth of the default, a cloth
/// soft enough to lie flat on itself. At the default each fold's bend
/// springs, squeezed to half their rest length, hold the layers' middles a
/// centimetre up on the folds (as a stiff fabric stands on its folds;
/// measured: the layers then lie 1.9 mm and 3.9 mm up at a tenth, 14 mm
/// and 29 mm at the default, on the semi-implicit step).
const BEND_STIFFNESS: f64 = 0.5;

/// `integrator` on the ground, the triangle method at the issue's
/// thickness, the bend springs at `BEND_STIFFNESS`.
fn params(integrator: Integrator) -> Params {
    let mut p = Params {
        integrator,
        dt: 1.0 / 600.0,
        ground: Some(Ground {
            height: 0.0,
            friction: 0.5,
        }),
        self_collision: Some(SelfCollision {
            thickness: Some(THICKNESS),
            method: ContactMethod::Triangles,
            ..SelfCollision::default()
        }),
        ..Params::default()
    };
    p.springs[SpringKind::Bend.index()].stiffness = BEND_STIFFNESS;
    p
}

fn solver<R: Real>(model: &Model, params: &Params, x: &[DVec3], v: &[DVec3]) -> CpuSolver<R> {
    let mut s = CpuSolver::<R>::new(model, params).expect("solver");
    s.set_state(State {
        x: x.iter().map(|&p| Vec3::from_f64(p)).collect(),
        v: v.iter().map(|&p| Vec3::from_f64(p)).collect(),
    })
    .expect("state");
    s
}

fn positions<R: Real>(s: &CpuSolver<R>) -> Vec<DVec3> {
    s.state()
        .x
        .iter()
        .map(|p| DVec3::from_array(p.to_f64()))
        .collect()
}

/// The point of triangle `t` nearest `p` (by regions, independently of the
/// solver's: inside the plane's projection, else the nearest of the
/// edges).
fn nearest_on(p: DVec3, t: [DVec3; 3]) -> DVec3 {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let q = p - n * (n.dot(p - t[0]) / n.length_squared());
    let inside = (0..3).all(|k| n.dot((t[(k + 1) % 3] - t[k]).cross(q - t[k])) >= 0.0);
    if inside {
        return q;
    }
    (0..3)
        .map(|k| {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let s = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            a + (b - a) * s
        })
        .min_by(|a, b| (*a - p).length().total_cmp(&(*b - p).length()))
        .unwrap_or(t[0])
}

/// The geometry checks, with the triangles binned by their boxes in cells
/// of a rest spacing (each check looks only at the cells its box covers).
struct Checks<'a> {
    model: &'a Model,
    edges: Vec<[u32; 2]>,
}

impl Checks<'_> {
    fn bins(&self, x: &[DVec3], pad: f64) -> HashMap<[i64; 3], Vec<usize>> {
        let mut bins: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for (k, t) in self.model.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|i| x[i as usize]);
            for cell in cells(a.min(b).min(c) - pad, a.max(b).max(c) + pad) {
                bins.entry(cell).or_default().push(k);
            }
        }
        bins
    }

    /// Mesh edges through a triangle they do not share a corner with.
    fn crossings(&self, x: &[DVec3]) -> usize {
        let bins = self.bins(x, 0.0);
        let mut found = std::collections::HashSet::new();
        for (e, &[i, j]) in self.edges.iter().enumerate() {
            let (a, b) = (x[i as usize], x[j as usize]);
            for cell in cells(a.min(b), a.max(b)) {
                for &k in bins.get(&cell).into_iter().flatten() {
                    let t = self.model.triangles[k];
                    if !t.contains(&i)
                        && !t.contains(&j)
                        && common::crosses(a, b, t.map(|c| x[c as usize]))
                    {
                        found.insert((e, k));
                    }
                }
            }
        }
        found.len()
    }

    /// Per vertex, the distance \[m\] to the nearest triangle it is not a
    /// corner of, if one lies within `radius`.
    fn nearest(&self, x: &[DVec3], radius: f64) -> Vec<Option<f64>> {
        let bins = self.bins(x, radius);
        (0..x.len())
            .map(|p| {
                let mut best: Option<f64> = None;
                for cell in cells(x[p], x[p]) {
                    for &k in bins.get(&cell).into_iter().flatten() {
                        let t = self.model.triangles[k];
                        if t.contains(&(p as u32)) {
                            continue;
                        }
                        let d = (nearest_on(x[p], t.map(|c| x[c as usize])) - x[p]).length();
                        if d < radius {
                            best = Some(best.map_or(d, |b| b.min(d)));
                        }
                    }
                }
                best
            })
            .collect()
    }
}

/// The cells of a spacing's size a box covers.
fn cells(lo: DVec3, hi: DVec3) -> Vec<[i64; 3]> {
    let (lo, hi) = ((lo / SPACING).floor(), (hi / SPACING).floor());
    let mut out = Vec::new();
    for i in lo.x as i64..=hi.x as i64 {
        for j in lo.y as i64..=hi.y as i64 {
            for k in lo.z as i64..=hi.z as i64 {
                out.push([i, j, k]);
            }
        }
    }
    out
}

/// Steps `s` `steps` times, checking each step for edges through
/// triangles and, with `min_gap`, for a vertex within `MIN_GAP`
/// thicknesses of a triangle it is not a corner of: the first failure, or
/// whether some vertex came within `close` \[m\] of such a triangle (the
/// test tested something).
fn run_checked<R: Real>(
    s: &mut CpuSolver<R>,
    checks: &Checks,
    steps: u64,
    close: f64,
    min_gap: bool,
) -> Result<bool, String> {
    let mut touched = false;
    for step in 1..=steps {
        s.step().expect("finite");
        let x = positions(s);
        let crossed = checks.crossings(&x);
        if crossed > 0 {
            return Err(format!("step {step}: {crossed} edges through triangles"));
        }
        let near = checks.nearest(&x, if min_gap { MIN_GAP * THICKNESS } else { 0.0 });
        if let Some((p, d)) = near.iter().enumerate().find_map(|(p, d)| d.map(|d| (p, d))) {
            return Err(format!(
                "step {step}: vertex {p} {d} m from a triangle, below {MIN_GAP} × {THICKNESS} m"
            ));
        }
        touched |= checks.nearest(&x, close).iter().any(Option::is_some);
    }
    Ok(touched)
}

/// Steps of the drop: 2/3 s, for the layers to fall onto one another
/// (the top one falls 7 cm) and onto the ground, and come to rest there
/// (the implicit and semi-implicit layers lie within a twentieth of a
/// millimetre of where they lie at 1 s).
const DROP_STEPS: u64 = 400;

/// The three-layer drop under `params` in precision `R`: its checks'
/// verdict ([`run_checked`]) and the positions at the end.
fn folded_drop<R: Real>(params: &Params) -> (Result<bool, String>, Model, Vec<DVec3>) {
    let model = model(LAYERS * LAYER_ROWS, params);
    let checks = Checks {
        model: &model,
        edges: edges(&model),
    };
    let start = folded(LAYERS, SPACING, 0.01);
    let mut s = solver::<R>(&model, params, &start, &vec![DVec3::ZERO; start.len()]);
    let verdict = run_checked(&mut s, &checks, DROP_STEPS, THICKNESS, true);
    let x = positions(&s);
    (verdict, model, x)
}

/// The median distance \[m\] from the upper layers' inner vertices to the
/// nearest other layer, over those within `LANDED` thicknesses of one,
/// and the fraction of them that are.
fn resting_gap(model: &Model, x: &[DVec3]) -> (f64, f64) {
    let checks = Checks {
        model,
        edges: edges(model),
    };
    let near = checks.nearest(x, LANDED * THICKNESS);
    let inner: Vec<usize> = (0..x.len())
        .filter(|&p| {
            let (i, j) = (p % N, p / N);
            let (layer, r) = (j / LAYER_ROWS, j % LAYER_ROWS);
            layer > 0 && (2..N - 2).contains(&i) && (2..LAYER_ROWS - 2).contains(&r)
        })
        .collect();
    let mut gaps: Vec<f64> = inner.iter().filter_map(|&p| near[p]).collect();
    gaps.sort_by(f64::total_cmp);
    let landed = gaps.len() as f64 / inner.len() as f64;
    (
        gaps.get(gaps.len() / 2).copied().unwrap_or(f64::INFINITY),
        landed,
    )
}

/// Of the upper layers' inner vertices, at least this fraction lies within
/// `LANDED` thicknesses of another layer at the end: the layers landed
/// (the premise of the resting bound).
const LANDED_FRACTION: f64 = 0.5;

fn check_drop<R: Real>(integrator: Integrator) {
    let (verdict, model, x) = folded_drop::<R>(&params(integrator));
    let what = format!("{integrator} {}", R::NAME);
    match verdict {
        Err(e) => panic!("{what}: {e}"),
        Ok(touched) => assert!(touched, "{what}: the layers never came within a thickness"),
    }
    if integrator == Integrator::Explicit {
        // The explicit step does not bring this start to rest within the
        // drop (its folds' squeezed springs throw the layers about: without
        // self-collision its lowest layer jumps 9 cm), so there is no rest
        // to measure.
        return;
    }
    let (gap, landed) = resting_gap(&model, &x);
    eprintln!("{what}: resting gap {gap} m, {landed} landed");
    assert!(
        landed >= LANDED_FRACTION,
        "{what}: only {landed} of the layers landed"
    );
    assert!(
        gap <= RESTING_GAP * THICKNESS,
        "{what}: the layers rest {gap} m apart, above {RESTING_GAP} × {THICKNESS} m"
    );
}

#[test]
fn folded_drop_explicit_f64() {
    check_drop::<f64>(Integrator::Explicit);
}

#[test]
fn folded_drop_explicit_f32() {
    check_drop::<f32>(Integrator::Explicit);
}

#[test]
fn folded_drop_implicit_f64() {
    check_drop::<f64>(Integrator::Implicit);
}

#[test]
fn folded_drop_implicit_f32() {
    check_drop::<f32>(Integrator::Implicit);
}

#[test]
fn folded_drop_semi_implicit_f64() {
    check_drop::<f64>(Integrator::SemiImplicit);
}

#[test]
fn folded_drop_semi_implicit_f32() {
    check_drop::<f32>(Integrator::SemiImplicit);
}

/// The checks can fail: without self-collision the same drop puts edges
/// through triangles.
#[test]
fn without_it_the_layers_cross() {
    let mut params = params(Integrator::Implicit);
    params.self_collision = None;
    let (verdict, _, _) = folded_drop::<f64>(&params);
    verdict.expect_err("the drop passed its checks without self-collision");
}

/// Relative speed \[m/s\] of the fold slammed shut.
const SLAM_SPEED: f64 = 5.0;

/// How near \[m\] the slammed layer comes to the other (the premise): the
/// bound slows it, 0.55 of the gap left a step at most, and the explicit
/// step's springs throw it back from four thicknesses.
const SLAM_CLOSE: f64 = 4.0 * THICKNESS;

/// Two layers 3 cm apart, the upper thrown down onto the lower (lying on
/// the ground) at `SLAM_SPEED`: 8 mm a step at 1/600 s, four thicknesses.
#[test]
fn a_fold_slammed_shut_crosses_nothing() {
    for integrator in Integrator::ALL {
        let params = params(integrator);
        let model = model(2 * LAYER_ROWS, &params);
        let checks = Checks {
            model: &model,
            edges: edges(&model),
        };
        let start = folded(2, 0.03, 0.0);
        let v: Vec<DVec3> = (0..start.len())
            .map(|p| {
                let down = p / N >= LAYER_ROWS;
                DVec3::new(0.0, if down { -SLAM_SPEED } else { 0.0 }, 0.0)
            })
            .collect();
        let mut s = solver::<f32>(&model, &params, &start, &v);
        match run_checked(&mut s, &checks, 60, SLAM_CLOSE, true) {
            Err(e) => panic!("{integrator}: {e}"),
            Ok(touched) => assert!(touched, "{integrator}: the layers never met"),
        }
    }
}

/// A hanging sheet pinned at its top corners, swinging from rest, never
/// comes within a thickness of itself nor moves a bound's length in a
/// step: it moves bit for bit as without self-collision.
#[test]
fn a_hanging_sheet_moves_exactly_as_without_it() {
    let model = common::swinging_sheet();
    for integrator in Integrator::ALL {
        let off = Params {
            integrator,
            ..Params::default()
        };
        let on = Params {
            self_collision: params(integrator).self_collision,
            ..off.clone()
        };
        let mut a = CpuSolver::<f32>::new(&model, &off).expect("off");
        let mut b = CpuSolver::<f32>::new(&model, &on).expect("on");
        for step in 1..=300 {
            a.step().expect("off");
            b.step().expect("on");
            assert_eq!(
                a.state(),
                b.state(),
                "{integrator}: step {step}: the triangle method changed a sheet that never \
                 touches itself"
            );
        }
    }
}

/// A scene with `[self_collision]` holding `keys` and the triangle method
/// (a 0.4 m cloth of 9², 5 cm spacing).
fn scene(keys: &str) -> wgcloth::Scene {
    let text = format!(
        "[cloth]\nresolution = [9, 9]\nsize = [0.4, 0.4]\n\n[self_collision]\nmethod = \"triangles\"\n{keys}\n"
    );
    wgcloth::Scene::from_toml(&text, std::path::Path::new("t.toml")).expect("scene")
}

/// A thickness below half a millimetre, or past four rest spacings, is
/// refused naming the key; one far below the spacing is not.
#[test]
fn thicknesses_are_refused_out_of_range_only() {
    for (thickness, ok) in [
        (0.0004, false),
        (0.0005, true),
        (0.002, true),
        (0.2, true),
        (0.21, false),
    ] {
        let s = scene(&format!("thickness = {thickness}"));
        let model = s.model().expect("model");
        match CpuSolver::<f64>::new(&model, &s.params) {
            Ok(_) => assert!(ok, "thickness {thickness} accepted"),
            Err(Error::InvalidParameter { key, .. }) if !ok => {
                assert_eq!(key, "self_collision.thickness");
            }
            Err(e) => panic!("thickness {thickness}: {e}"),
        }
    }
}

/// The GPU solvers refuse the method (they have not got it yet) naming
/// the key, rather than step without it.
#[test]
fn the_gpu_refuses_it_naming_the_key() {
    let s = scene("");
    let model = s.model().expect("model");
    let ctx = match wgcloth::gpu::GpuContext::new(None) {
        Ok(c) => c,
        Err(e) => panic!("GPU tests need an adapter: {e}"),
    };
    match wgcloth::gpu::GpuSolver::new(&ctx.device, &ctx.queue, &model, &s.params) {
        Err(Error::InvalidParameter { key, .. }) => assert_eq!(key, "self_collision.method"),
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("the GPU accepted the triangle method"),
    }
}

/// Checks of a built-in scene's model.
fn scene_checks(model: &Model) -> Checks<'_> {
    Checks {
        model,
        edges: edges(model),
    }
}

/// The built-in `layers` with its middle cloth coarsened to half the
/// others' resolution (13² over 0.75 m: a 6.25 cm spacing on 3.1 cm ones),
/// the triangle method on: the three fall onto the ball and onto one
/// another, in `f32`, and no edge of either resolution passes through a
/// triangle of the other at any step of the first 1.5 s. The gap is not
/// held to `MIN_GAP` here: at the ball's top the coarse cloth's flat
/// triangles, pulled onto the ball by its tension, come within 0.38 of a
/// thickness of the fine cloth's apex (they cannot follow its curvature,
/// and the bound lets the contact lift them by 0.45 of the gap a step).
#[test]
fn cloths_of_two_resolutions_pressed_together_cross_nothing() {
    let mut scene = wgcloth::Scene::builtin("layers").expect("built in");
    scene.cloths[1].spec.nx = 13;
    scene.cloths[1].spec.ny = 13;
    scene.params.self_collision = params(Integrator::Implicit).self_collision;
    let model = scene.model().expect("model");
    let mut s = CpuSolver::<f32>::new(&model, &scene.params).expect("solver");
    match run_checked(&mut s, &scene_checks(&model), 360, THICKNESS, false) {
        Err(e) => panic!("{e}"),
        Ok(touched) => assert!(touched, "the cloths never met"),
    }
}

/// The built-in `tablecloth` (an irregular mesh of 631 vertices falling
/// onto the `table` mesh collider), the triangle method on, in `f32`: as
/// it drapes over the table's edge and folds, no edge passes through a
/// triangle at any step of the first 2 s.
#[test]
fn a_mesh_draping_over_a_mesh_collider_crosses_nothing() {
    let mut scene = wgcloth::Scene::builtin("tablecloth").expect("built in");
    scene.params.self_collision = params(Integrator::Implicit).self_collision;
    let model = scene.model().expect("model");
    let mut s = CpuSolver::<f32>::new(&model, &scene.params).expect("solver");
    if let Err(e) = run_checked(&mut s, &scene_checks(&model), 240, THICKNESS, true) {
        panic!("{e}");
    }
}

/// How fast the sheet of the throw is thrown \[m/s\]: 2.5 cm a step at
/// 1/240 s, more than two rounds' bounds in open cloth.
const THROW_SPEED: f64 = 6.0;

/// A flat metre of 33² thrown down at `THROW_SPEED` in free fall (no
/// ground) at 1/240 s: nothing comes near anything else, and the rounds
/// carry every vertex all the way each step though one round's bound
/// would stop it short, so it moves bit for bit as without
/// self-collision, on every integrator.
#[test]
fn a_thrown_sheet_moves_exactly_as_without_it() {
    let dt = 1.0 / 240.0;
    for integrator in Integrator::ALL {
        let mut on = params(integrator);
        on.dt = dt;
        on.ground = None;
        let off = Params {
            self_collision: None,
            ..on.clone()
        };
        let model = model(N, &on);
        let one_round = BOUND_FRACTION * (THICKNESS + self_collision::triangle_gap(&model));
        assert!(
            THROW_SPEED * dt > 2.0 * one_round,
            "the premise: a step's fall {} m needs more than two rounds of {one_round} m",
            THROW_SPEED * dt
        );
        let x = model.rest_positions.clone();
        let v = vec![DVec3::new(0.0, -THROW_SPEED, 0.0); x.len()];
        let mut a = solver::<f32>(&model, &off, &x, &v);
        let mut b = solver::<f32>(&model, &on, &x, &v);
        for step in 1..=30 {
            a.step().expect("off");
            b.step().expect("on");
            assert_eq!(
                a.state(),
                b.state(),
                "{integrator}: step {step}: the thrown sheet was slowed or moved"
            );
        }
    }
}

/// A `[[cloth]]` table: a free horizontal sheet of `n²` particles over
/// `size` \[m\], centred on the vertical axis at height `y` \[m\].
fn sheet(n: usize, size: f64, y: f64) -> String {
    format!(
        "[[cloth]]\nresolution = [{n}, {n}]\nsize = [{size}, {size}]\n\
         origin = [{}, {y}, {}]\norientation = \"horizontal\"\nmass = 0.1\npins = []\n",
        -size / 2.0,
        -size / 2.0
    )
}

/// Gap \[m\] between the two sheets of the stack that falls whole: two
/// thicknesses, so every vertex has a pair 4 mm away and its bound is
/// 1.8 mm a step.
const STACK_GAP: f64 = 2.0 * THICKNESS;

/// Two flat sheets of 17² over half a metre, one `STACK_GAP` above the
/// other, falling freely (no ground) from rest for half a second at 1/240
/// s, to 4.9 m/s (2 cm a step, ten times their bound): they fall as one,
/// so the bound relative to their common translation never stops them,
/// and they move bit for bit as without self-collision, on every
/// integrator.
#[test]
fn a_stack_falling_whole_moves_exactly_as_without_it() {
    for integrator in Integrator::ALL {
        let text = format!(
            "[simulation]\nintegrator = \"{}\"\ndt = {}\n\n{}\n{}\n\
             [self_collision]\nmethod = \"triangles\"\nthickness = {THICKNESS}\n",
            integrator.as_str(),
            1.0 / 240.0,
            sheet(17, 0.5, 1.0),
            sheet(17, 0.5, 1.0 + STACK_GAP),
        );
        let scene =
            wgcloth::Scene::from_toml(&text, std::path::Path::new("stack.toml")).expect("scene");
        let model = scene.model().expect("model");
        let off = Params {
            self_collision: None,
            ..scene.params.clone()
        };
        let mut a = CpuSolver::<f32>::new(&model, &off).expect("off");
        let mut b = CpuSolver::<f32>::new(&model, &scene.params).expect("on");
        for step in 1..=120 {
            a.step().expect("off");
            b.step().expect("on");
            assert_eq!(
                a.state(),
                b.state(),
                "{integrator}: step {step}: the falling stack was slowed or moved"
            );
        }
        let speed = -b.velocities()[0].y;
        assert!(
            speed > 4.5,
            "{integrator}: the premise: falling at {speed} m/s"
        );
    }
}

/// How fast the upper sheet of the slide is thrown along the lower [m/s]:
/// 4.2 mm a step at 1/240 s, 4.6 of its bound (0.45 of the thickness
/// between them).
const SLIDE_SPEED: f64 = 1.0;

/// A small sheet (9² over 0.2 m) lying a thickness above a large one (17²
/// over 0.8 m) on the ground, thrown along it at `SLIDE_SPEED` with no
/// friction between them, for 0.1 s at 1/240 s: each round takes it its
/// bound along the lower sheet (its way there with what would close on
/// it taken out), so it slides more than three bounds a step, where one
/// round held it to one; and it crosses nothing.
#[test]
fn a_sheet_slides_along_another_several_bounds_a_step() {
    let text = format!(
        "[simulation]\nintegrator = \"implicit\"\ndt = {}\n\n{}\n{}\n\
         [ground]\nheight = 0.0\nfriction = 0.8\n\n\
         [self_collision]\nmethod = \"triangles\"\nthickness = {THICKNESS}\nfriction = 0.0\n",
        1.0 / 240.0,
        sheet(17, 0.8, 0.0),
        sheet(9, 0.2, THICKNESS),
    );
    let scene =
        wgcloth::Scene::from_toml(&text, std::path::Path::new("slide.toml")).expect("scene");
    let model = scene.model().expect("model");
    let lower = 17 * 17;
    let x = model.rest_positions.clone();
    let v: Vec<DVec3> = (0..x.len())
        .map(|p| DVec3::new(if p >= lower { SLIDE_SPEED } else { 0.0 }, 0.0, 0.0))
        .collect();
    let mut s = solver::<f32>(&model, &scene.params, &x, &v);
    let steps = 24;
    let checks = scene_checks(&model);
    if let Err(e) = run_checked(&mut s, &checks, steps, THICKNESS, true) {
        panic!("{e}");
    }
    let moved = positions(&s)[lower..]
        .iter()
        .zip(&x[lower..])
        .map(|(a, b)| a.x - b.x)
        .sum::<f64>()
        / (x.len() - lower) as f64;
    // Its bound a step, a thickness from the lower sheet.
    let bounds = moved / (BOUND_FRACTION * THICKNESS * steps as f64);
    println!("slid {moved} m in {steps} steps: {bounds} bounds a step");
    assert!(
        bounds > 3.0,
        "the upper sheet slid {moved} m, {bounds} bounds a step, not three"
    );
}
