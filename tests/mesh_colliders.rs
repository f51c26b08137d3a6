//! Mesh colliders (`[[collider]]`, `wgcloth::sdf`) on every integrator and
//! both backends: a cloth rests on a baked sphere where it rests on the
//! analytic one, never sinks into a box or a non-convex body deeper than
//! the grid allows, is carried by a moving body's friction; the GPU is the
//! `f32` mirror bit for bit on both step paths, in a batch and with poses
//! set every frame; an open mesh and bad keys are refused.

#[path = "common/closed_meshes.rs"]
mod closed_meshes;
mod gpu_common;

use gpu_common::agreement::{self, Stepper};

use std::path::Path;
use std::sync::Arc;

use closed_meshes::{uv_sphere, voxels};
use gpu_common::*;
use wgcloth::cpu::CpuSolver;
use wgcloth::glam::{DQuat, DVec3};
use wgcloth::gpu::{GpuBatch, GpuSolver, StepPath};
use wgcloth::mesh::Mesh;
use wgcloth::model::ClothSpec;
use wgcloth::params::{FixupMethod, Integrator, Sphere};
use wgcloth::sdf::{bake, MeshCollider, MeshPose};
use wgcloth::{Model, Params, Scene, Vector};

/// A mesh collider baked from OBJ `text`, scaled, at `position`.
fn collider(
    text: &str,
    scale: f64,
    position: DVec3,
    resolution: u32,
    thickness: f64,
) -> MeshCollider {
    let path = Path::new("test.obj");
    let mesh =
        Mesh::parse(text.as_bytes(), path, None, &|_| Err("none".into())).expect("valid mesh");
    let grid = bake(&mesh, path, "collider[0]", scale, resolution, thickness).expect("bakes");
    MeshCollider {
        path: path.into(),
        grid: Arc::new(grid),
        position,
        rotation: DQuat::IDENTITY,
        velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        friction: 0.5,
        thickness,
    }
}

/// The collider tests' parameters (as tests/colliders.rs): dt 1 ms for
/// explicit, 1/240 s otherwise; the Jacobi fix-up (the GPU's).
fn collider_params(integrator: Integrator) -> Params {
    let mut params = Params {
        integrator,
        dt: if integrator == Integrator::Explicit {
            1e-3
        } else {
            1.0 / 240.0
        },
        ..Params::default()
    };
    params.fixup.method = FixupMethod::Jacobi;
    params
}

/// A horizontal `n` × `n` cloth `size` m square centred at `centre`.
fn cloth(n: usize, size: f64, centre: DVec3, params: &Params) -> Model {
    let spec = ClothSpec {
        nx: n,
        ny: n,
        size: [size, size],
        origin: centre - DVec3::new(size / 2.0, 0.0, size / 2.0),
        pins: vec![],
        ..ClothSpec::default()
    };
    Model::new(&spec, &params.springs).expect("valid grid")
}

/// The baked sphere: radius 0.3 m, 24 rings × 48 segments, 48 cells
/// across (a 12.5 mm cell).
const RADIUS: f64 = 0.3;
const RINGS: usize = 24;
const SEGMENTS: usize = 48;
const SPHERE_RESOLUTION: u32 = 48;
/// The tessellation's error: a face lies inside the sphere by at most
/// `r (1 − cos α)`, `α` the angle from a quad's corner to its centre,
/// below ¾ of the 7.5° spacing.
fn sagitta() -> f64 {
    RADIUS * (1.0 - (0.75 * std::f64::consts::PI / RINGS as f64).cos())
}

#[test]
fn a_cloth_rests_on_a_baked_sphere_where_it_rests_on_the_analytic_one() {
    // The bound: the grid spacing plus the tessellation error.
    let cell = 2.0 * RADIUS / f64::from(SPHERE_RESOLUTION);
    let tolerance = cell + sagitta();
    let centre = DVec3::new(0.0, 0.5, 0.0);
    for integrator in Integrator::ALL {
        let mut params = collider_params(integrator);
        let model = cloth(10, 0.5, centre + DVec3::Y * (RADIUS + 0.1), &params);
        let steps = (1.0 / params.dt).round() as u64;
        params.spheres = vec![Sphere {
            center: centre,
            radius: RADIUS,
            friction: 0.5,
            velocity: DVec3::ZERO,
        }];
        let analytic = run_f64(&model, &params, steps);
        params.spheres.clear();
        params.mesh_colliders = vec![collider(
            &uv_sphere(RINGS, SEGMENTS),
            RADIUS,
            centre,
            SPHERE_RESOLUTION,
            0.0,
        )];
        let baked = run_f64(&model, &params, steps);
        // Where the cloth touches both spheres, the baked one holds it at
        // the radius the analytic one does (the drape beyond the contact
        // is free to differ: it is a fold's chaotic dynamics, not contact).
        let mut worst = (0.0f64, 0);
        let mut touching = 0;
        for (p, (a, b)) in analytic.iter().zip(&baked).enumerate() {
            let (ra, rb) = ((*a - centre).length(), (*b - centre).length());
            if ra < RADIUS + 1e-3 && rb < RADIUS + tolerance {
                touching += 1;
                let e = (rb - ra).abs();
                if e > worst.0 {
                    worst = (e, p);
                }
            }
        }
        assert!(
            touching >= 4,
            "{integrator}: only {touching} particles touch both spheres"
        );
        let top = |x: &[DVec3]| x.iter().map(|p| p.y).fold(f64::MIN, f64::max);
        eprintln!(
            "{integrator}: worst radial difference {:.2e} m (particle {}), tops {:.4} / {:.4} m, \
             tolerance {tolerance:.2e} m",
            worst.0,
            worst.1,
            top(&analytic),
            top(&baked)
        );
        assert!(
            worst.0 <= tolerance,
            "{integrator}: particle {} rests {:.2e} m off where it rests on the analytic sphere",
            worst.1,
            worst.0
        );
        assert!((top(&analytic) - top(&baked)).abs() <= tolerance);
    }
}

/// The positions after `steps` of the `f64` reference.
fn run_f64(model: &Model, params: &Params, steps: u64) -> Vec<DVec3> {
    let mut s = CpuSolver::<f64>::new(model, params).expect("valid");
    s.step_n(steps).expect("stable");
    s.positions()
        .iter()
        .map(|p| DVec3::from_array(p.to_f64()))
        .collect()
}

/// The voxel bodies: a 0.4 m box, and a U (three voxels wide, two high,
/// the middle top one empty: a 0.2 m notch), 0.2 m voxels, centred under
/// the cloth.
const VOXEL: f64 = 0.2;
/// Which voxels of a body are filled.
type Filled = fn(i32, i32, i32) -> bool;

fn bodies() -> [(&'static str, [i32; 3], Filled); 2] {
    [
        ("box", [2, 2, 2], |_, _, _| true),
        ("U", [3, 2, 2], |i, j, _| !(i == 1 && j == 1)),
    ]
}
/// The bodies' grid: 32 cells along the longest side (a 12.5–18.75 mm
/// cell), a thickness of 5 mm.
const BODY_RESOLUTION: u32 = 32;
const THICKNESS: f64 = 0.005;

/// How deep `x` is inside the union of the body's voxels \[m\] (0 outside):
/// its distance to the nearest empty voxel of the grid padded by one.
fn depth(n: [i32; 3], filled: Filled, origin: DVec3, x: DVec3) -> f64 {
    let inside = |i: i32, j: i32, k: i32| {
        (0..n[0]).contains(&i)
            && (0..n[1]).contains(&j)
            && (0..n[2]).contains(&k)
            && filled(i, j, k)
    };
    let local = (x - origin) / VOXEL;
    let here = local.floor().as_ivec3();
    if !inside(here.x, here.y, here.z) {
        return 0.0;
    }
    let mut best = f64::MAX;
    for i in -1..=n[0] {
        for j in -1..=n[1] {
            for k in -1..=n[2] {
                if inside(i, j, k) {
                    continue;
                }
                let lo = DVec3::new(i as f64, j as f64, k as f64);
                let d = (lo - local).max(local - (lo + DVec3::ONE)).max(DVec3::ZERO);
                best = best.min(d.length() * VOXEL);
            }
        }
    }
    best
}

/// How deep a particle may be inside a body at the end of a step: the
/// trilinear field's zero set lies within a few hundredths of a cell of a
/// flat face but cuts corners at an edge (where the field has a crease)
/// by up to about half a cell's diagonal less the thickness; a quarter of
/// the 18.75 mm cell bounds what the runs show (0.8 mm on the U, none on
/// the box; see the printed worst) with room for the dynamics.
const DEPTH_TOLERANCE: f64 = 0.25 * 0.6 / BODY_RESOLUTION as f64;

#[test]
fn no_particle_sinks_into_a_box_or_a_non_convex_body_on_any_backend() {
    for (name, n, filled) in bodies() {
        let size = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64) * VOXEL;
        let origin = DVec3::new(-size.x / 2.0, 0.1, -size.z / 2.0);
        let text = voxels(n, filled);
        let body = collider(&text, VOXEL, origin, BODY_RESOLUTION, THICKNESS);
        for integrator in Integrator::ALL {
            let mut params = collider_params(integrator);
            params.mesh_colliders = vec![body.clone()];
            let model = cloth(12, 0.8, DVec3::new(0.0, 0.1 + size.y + 0.05, 0.0), &params);
            let steps = (0.4 / params.dt).round() as usize;
            let mut f64s = CpuSolver::<f64>::new(&model, &params).expect("valid");
            let mut f32s = CpuSolver::<f32>::new(&model, &params).expect("valid");
            let mut g = exact_gpu(&model, &params);
            let mut worst = (0.0f64, "", 0, 0);
            let mut touched = false;
            let bound = agreement::step_bound(&params);
            for step in 0..steps {
                let before = agreement::before_step(&g, &mut f32s);
                f64s.step().expect("stable");
                f32s.step().expect("stable");
                g.step(1).expect("GPU step");
                let gs = g.read_state().expect("read-back");
                let what = format!("{name} {integrator}, step {step}");
                agreement::check_after_step(&what, &before, &(gs.x.clone(), gs.v), &f32s, &bound)
                    .unwrap_or_else(|e| panic!("{e}"));
                let f64x: Vec<DVec3> = f64s
                    .positions()
                    .iter()
                    .map(|p| DVec3::from_array(p.to_f64()))
                    .collect();
                let gx: Vec<DVec3> = gs.x.iter().map(|p| p.as_dvec3()).collect();
                for (what, xs) in [("f64", &f64x), ("GPU", &gx)] {
                    for (p, x) in xs.iter().enumerate() {
                        let d = depth(n, filled, origin, *x);
                        if d > worst.0 {
                            worst = (d, what, step, p);
                        }
                        touched |= x.y < origin.y + size.y + 2.0 * THICKNESS;
                    }
                }
            }
            eprintln!(
                "{name} {integrator}: deepest {:.2e} m ({} step {} particle {}), tolerance {:.2e} m",
                worst.0, worst.1, worst.2, worst.3, DEPTH_TOLERANCE
            );
            assert!(
                touched,
                "{name} {integrator}: the cloth never reached the body"
            );
            assert!(
                worst.0 <= DEPTH_TOLERANCE,
                "{name} {integrator}: {} particle {} at step {} is {:.2e} m inside",
                worst.1,
                worst.3,
                worst.2,
                worst.0
            );
        }
    }
}

/// The moving box's speed sideways [m/s] (as the moving sphere's in
/// tests/colliders.rs).
const BOX_SPEED: f64 = 0.5;
/// The rule for the sphere: friction 1 carries the cloth at least
/// half the body's displacement in 1 s.
const CARRIED_FRACTION: f64 = 0.5;
/// Without friction a flat top pushes nothing sideways: a quarter of what
/// friction carries bounds what the cloth's fall and its edges' drape
/// over the box's sides give it.
const FRICTIONLESS_FRACTION: f64 = 0.25;

/// How far a cloth resting flat on the box's top may be from it \[m\]:
/// contact holds it at the thickness up to the grid's error on a flat
/// face (well below a millimetre), and a 10 × 10 cloth sags by less
/// between its rows.
const ON_TOP: f64 = 2e-3;

/// A 10 × 10 cloth, 0.3 m square, resting on a 0.6 m box moving along +x.
fn on_a_box(integrator: Integrator, friction: f64) -> (Model, Params) {
    let mut params = collider_params(integrator);
    let mut body = collider(
        &voxels([1, 1, 1], |_, _, _| true),
        0.6,
        DVec3::new(-0.3, 0.0, -0.3),
        16,
        THICKNESS,
    );
    body.friction = friction;
    body.velocity = DVec3::new(BOX_SPEED, 0.0, 0.0);
    params.mesh_colliders = vec![body];
    let model = cloth(
        10,
        0.3,
        DVec3::new(0.0, 0.6 + THICKNESS + 1e-3, 0.0),
        &params,
    );
    (model, params)
}

fn mean_x<V: Vector>(x: &[V]) -> f64 {
    x.iter().map(|p| p.to_f64()[0]).sum::<f64>() / x.len() as f64
}

#[test]
fn a_moving_mesh_collider_carries_a_resting_cloth_by_friction_and_not_without() {
    for integrator in Integrator::ALL {
        let carried = |friction: f64| {
            let (model, params) = on_a_box(integrator, friction);
            let steps = (1.0 / params.dt).round() as u64;
            let mut f64s = CpuSolver::<f64>::new(&model, &params).expect("valid");
            let start = mean_x(&f64s.positions());
            f64s.step_n(steps).expect("stable");
            let x = f64s.positions();
            // Carried with friction, the cloth is still on the box's top
            // where the box has gone, not slid off where it was.
            let top = 0.6 + THICKNESS;
            let low = x.iter().map(|p| p.to_f64()[1]).fold(f64::MAX, f64::min);
            if friction > 0.0 {
                assert!(
                    (low - top).abs() < ON_TOP,
                    "{integrator}: the cloth's lowest particle at {low:.4} m, the top at {top} m"
                );
            }
            mean_x(&x) - start
        };
        let moved = BOX_SPEED * 1.0;
        let (with, without) = (carried(1.0), carried(0.0));
        eprintln!("{integrator}: carried {with:.3} m with friction 1, {without:.3} m without");
        assert!(
            with >= CARRIED_FRACTION * moved,
            "{integrator}: friction 1 carried the cloth {with:.3} m of the box's {moved} m"
        );
        assert!(
            without.abs() < FRICTIONLESS_FRACTION * with,
            "{integrator}: without friction the cloth still moved {without:.3} m ({with:.3} m with)"
        );
    }
}

/// Frames of the per-frame tests and steps per frame.
const FRAMES: u32 = 8;
const FRAME_STEPS: u32 = 10;

/// The pose of frame `k` of the per-frame tests: turning about y and
/// moving in a circle, spinning.
fn pose(k: u32, position: DVec3) -> MeshPose {
    let angle = f64::from(k) * 0.3;
    MeshPose {
        position,
        rotation: DQuat::from_rotation_y(angle * 0.5),
        velocity: DVec3::new(angle.cos(), 0.0, angle.sin()) * 0.3,
        angular_velocity: DVec3::new(0.0, 0.8, 0.0),
    }
}

/// A host moving and turning a mesh collider frame by frame drives the GPU
/// on both step paths, a batch of two cloths and the `f32` mirror alike:
/// every step under the agreement policy (bit for bit on lavapipe).
#[test]
fn poses_set_every_frame_move_the_gpu_paths_a_batch_and_the_mirror_alike() {
    let ctx = gpu();
    for integrator in Integrator::ALL {
        let (model, params) = on_a_box(integrator, 1.0);
        let start = params.mesh_colliders[0].position;
        let mut f32s = CpuSolver::<f32>::new(&model, &params).expect("valid");
        let mut paths: Vec<(String, GpuSolver)> = [StepPath::Workgroup, StepPath::MultiDispatch]
            .into_iter()
            .map(|path| {
                let mut g = solver_on(&model, &params, path);
                g.tuning_mut().set_adaptive_cg_budget(false);
                (format!("{path}"), g)
            })
            .collect();
        let mut batch = GpuBatch::with_kernels(ctx.kernels(), &ctx.queue);
        let ids = [
            batch.add(&model, &params).expect("a"),
            batch.add(&model, &params).expect("b"),
        ];
        // A mirror per solver and one for the batch's first cloth, each
        // compared after every step under the agreement policy.
        let mut mirrors: Vec<CpuSolver<f32>> = (0..=paths.len()).map(|_| f32s.clone()).collect();
        let bound = agreement::step_bound(&params);
        let frame = params.dt * f64::from(FRAME_STEPS);
        let mut position = start;
        let mut batch = agreement::BatchCloth { batch, id: ids[0] };
        for k in 0..FRAMES {
            let p = pose(k, position);
            for m in &mut mirrors {
                m.set_mesh_colliders(&[p]).expect("valid pose");
            }
            f32s.set_mesh_colliders(&[p]).expect("valid pose");
            for (_, g) in &mut paths {
                g.set_mesh_colliders(&[p]).expect("valid pose");
            }
            for id in ids {
                batch
                    .batch
                    .set_mesh_colliders(id, &[p])
                    .expect("valid pose");
            }
            f32s.step_n(u64::from(FRAME_STEPS)).expect("stable");
            for step in 0..FRAME_STEPS {
                let at = k * FRAME_STEPS + step;
                let units = paths
                    .iter_mut()
                    .map(|(name, g)| (name.clone(), g as &mut dyn Stepper))
                    .chain([("batch".to_string(), &mut batch as &mut dyn Stepper)]);
                for ((name, unit), mirror) in units.zip(&mut mirrors) {
                    let before = agreement::before_step(unit, mirror);
                    unit.advance(1).expect("GPU step");
                    mirror.step().expect("stable");
                    let what = format!("{integrator} {name}, step {at}");
                    agreement::check_after_step(&what, &before, &unit.state(), mirror, &bound)
                        .unwrap_or_else(|e| panic!("{e}"));
                }
            }
            position += p.velocity * frame;
        }
        let moved = mean_x(&f32s.positions()) - mean_x(&model.rest_positions);
        assert!(moved.abs() > 1e-3, "{integrator}: the body moved the cloth");
        // The batch's two copies are the same kernels on the same inputs:
        // the same bits on every adapter.
        let (a, b) = (
            batch.batch.read_state(ids[0]).expect("batch read-back"),
            batch.batch.read_state(ids[1]).expect("batch read-back"),
        );
        assert!(
            a.x.iter()
                .zip(&b.x)
                .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits)),
            "{integrator}: the batch's two copies differ"
        );
    }
}

#[test]
fn more_mesh_colliders_than_the_gpu_holds_and_a_wrong_pose_count_are_refused() {
    let ctx = gpu();
    let (model, mut params) = on_a_box(Integrator::Implicit, 1.0);
    let max = wgcloth::kernel_config::MAX_MESH_COLLIDERS;
    params.mesh_colliders = vec![params.mesh_colliders[0].clone(); max + 1];
    let Err(e) = GpuSolver::new(&ctx.device, &ctx.queue, &model, &params) else {
        panic!("{} mesh colliders were taken", max + 1);
    };
    assert!(e.to_string().contains(&format!("at most {max}")), "{e}");
    params.mesh_colliders.truncate(1);
    let mut g = exact_gpu(&model, &params);
    let p = params.mesh_colliders[0].pose();
    let e = g
        .set_mesh_colliders(&[p, p])
        .expect_err("two poses for one body");
    assert!(e.to_string().contains("one pose per mesh collider"), "{e}");
    let bad = MeshPose {
        rotation: DQuat::from_xyzw(0.0, 0.0, 0.0, 2.0),
        ..p
    };
    let e = g.set_mesh_colliders(&[bad]).expect_err("not a rotation");
    assert!(e.to_string().contains("collider[0].rotation"), "{e}");
}

/// A scene with one collider whose keys are `keys`, its mesh `mesh.obj`
/// in a fresh folder holding `obj`.
fn scene_with(obj: &str, keys: &str) -> (std::path::PathBuf, wgcloth::Result<Scene>) {
    scene_text(obj, &format!("[[collider]]\nmesh = \"mesh.obj\"\n{keys}\n"))
}

/// The scene file `text` beside `mesh.obj` holding `obj`, in a fresh
/// folder (returned, for removal).
fn scene_text(obj: &str, text: &str) -> (std::path::PathBuf, wgcloth::Result<Scene>) {
    let dir = std::env::temp_dir().join(format!(
        "wgcloth-mesh-collider-{}-{}",
        std::process::id(),
        text.len() + obj.len()
    ));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("mesh.obj"), obj).expect("mesh written");
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).expect("scene written");
    let scene = Scene::load(&path);
    (dir, scene)
}

/// A character walking 1 m along +z in 1 s, turning 90°, carrying a box.
const CHARACTER: &str = "[character]\n\
    [[character.key]]\ntime = 0.0\nposition = [0, 0, 0]\n\
    [[character.key]]\ntime = 1.0\nposition = [0, 0, 1]\nyaw = 90\n\
    [[character.collider]]\nmesh = \"mesh.obj\"\nposition = [0, 1, 0]\n";

#[test]
fn a_character_carries_its_mesh_colliders_along_its_keys() {
    let cube = voxels([1, 1, 1], |_, _, _| true);
    let (dir, scene) = scene_text(&cube, CHARACTER);
    let _ = std::fs::remove_dir_all(dir);
    let scene = scene.expect("a character with a mesh collider");
    // Posed at the first key, after the scene's own (none here).
    assert_eq!(scene.params.mesh_colliders.len(), 1);
    assert_eq!(scene.params.mesh_colliders[0].position, DVec3::Y);
    let model = cloth(4, 0.2, DVec3::new(0.0, 2.5, 0.0), &scene.params);
    let animation = scene.animation(&model).expect("a character");
    let frame = 0.1;
    let pose = animation.mesh_poses(0.5, frame)[0];
    // Halfway: at z = 0.5, moving at 1 m/s along z (the frame's
    // displacement over its length), turned 45°, turning at 90°/s.
    let rate = std::f64::consts::FRAC_PI_2;
    assert!(
        (pose.position - DVec3::new(0.0, 1.0, 0.5)).length() < 1e-9,
        "{pose:?}"
    );
    assert!((pose.velocity - DVec3::Z).length() < 1e-9, "{pose:?}");
    assert!(
        (pose.angular_velocity - DVec3::Y * rate).length() < 1e-9,
        "{pose:?}"
    );
    assert!((pose.rotation.to_axis_angle().1 - rate / 2.0).abs() < 1e-9);
    // Applied to a solver, it is the solver's body.
    let mut s = CpuSolver::<f64>::new(&model, &scene.params).expect("valid");
    animation.apply(&mut s, 0.5, frame).expect("valid poses");
    // A character's collider takes no velocity of its own.
    let (dir, scene) = scene_text(&cube, &format!("{CHARACTER}velocity = [1, 0, 0]\n"));
    let _ = std::fs::remove_dir_all(dir);
    let msg = scene.expect_err("velocity refused").to_string();
    assert!(
        msg.contains("velocity") && msg.contains("character.collider"),
        "{msg}"
    );
}

#[test]
fn an_open_mesh_and_bad_collider_keys_are_refused_naming_the_file_and_the_key() {
    let cube = voxels([1, 1, 1], |_, _, _| true);
    let (dir, scene) = scene_with(&cube, "position = [0, 0.5, 0]\nrotation = [0, 1, 0, 30]");
    let scene = scene.expect("a closed cube is taken");
    let c = &scene.params.mesh_colliders[0];
    assert!((c.rotation.to_axis_angle().1.to_degrees() - 30.0).abs() < 1e-9);
    assert_eq!(c.thickness, 0.005);
    let _ = std::fs::remove_dir_all(dir);
    // Five faces of the cube: open.
    let open: String = cube
        .lines()
        .filter(|l| *l != cube.lines().last().unwrap_or(""))
        .map(|l| format!("{l}\n"))
        .collect();
    let (dir, scene) = scene_with(&open, "");
    let msg = scene.expect_err("an open mesh").to_string();
    assert!(
        msg.contains("mesh.obj") && msg.contains("is open") && msg.contains("line"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(dir);
    let rows: [(&str, &[&str]); 5] = [
        ("resolution = 2", &["collider[0].resolution", "4 to 512"]),
        ("thickness = -1", &["collider[0].thickness", "≥ 0"]),
        (
            "rotation = [0, 0, 0, 30]",
            &["collider[0].rotation", "axis"],
        ),
        ("friction = -1", &["collider[0].friction"]),
        (
            "velocity = [1, nan, 0]",
            &["collider[0].velocity", "finite"],
        ),
    ];
    for (keys, wanted) in rows {
        let (dir, scene) = scene_with(&cube, keys);
        let msg = scene
            .err()
            .unwrap_or_else(|| panic!("refused: {keys}"))
            .to_string();
        for w in wanted.iter().chain(&["scene.toml"]) {
            assert!(msg.contains(w), "{keys:?}: message lacks {w:?}: {msg}");
        }
        let _ = std::fs::remove_dir_all(dir);
    }
}

/// The built-in `table` at dt 1/60 s: the cloth meets the table top at
/// 1.6 m/s, 2.6 cm a step, more than half the top's 4 cm (plus the 1.2 cm
/// thickness on each side), so the nearest face at the end of the entry
/// step is the top's underside.
fn fast_table() -> (Model, Params) {
    let mut scene = Scene::builtin("table").expect("built in");
    scene.params.dt = 1.0 / 60.0;
    (scene.model().expect("valid"), scene.params)
}

/// The table top's upper face [m] (0.76 m high, plus the collider's
/// 0.012 m thickness) and the half-sides of its footprint (1.2 × 0.8 m).
const TOP: f64 = 0.772;
const HALF_LENGTH: f64 = 0.6;
const HALF_WIDTH: f64 = 0.4;
/// How far below the upper face a particle over the top may sit \[m\]: the
/// 1.9 cm grid rounds the surface by a fraction of a cell; a particle
/// pushed out through the underside sits 6.4 cm lower.
const ON_THE_TOP: f64 = 0.01;
/// Steps the GPU runs against its mirror: the cloth reaches the top at
/// step 10.
const FAST_TABLE_GPU_STEPS: u32 = 16;

/// A particle whose step crosses more than half of a thin part leaves by
/// the face it came through: the fast cloth lies on the table top, none of
/// it under it, on every backend (the GPU on both paths, the mirror's
/// bits here).
#[test]
fn a_cloth_falling_fast_onto_a_thin_table_top_lands_on_it() {
    let (model, params) = fast_table();
    let f64s = run_checked_f64(&model, &params, 60);
    let x = f64s.positions();
    let over: Vec<&DVec3> = x
        .iter()
        .filter(|p| p.x.abs() < HALF_LENGTH - 0.05 && p.z.abs() < HALF_WIDTH - 0.05)
        .collect();
    assert!(!over.is_empty(), "no particle over the top");
    let lowest = over.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    assert!(
        lowest > TOP - ON_THE_TOP,
        "a particle over the top lies at y = {lowest} m, under its face at {TOP} m"
    );
    assert_both_paths_agree("fast table", &model, &params, FAST_TABLE_GPU_STEPS);
}
