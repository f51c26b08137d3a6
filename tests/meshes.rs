//! Mesh cloths (`[cloth] mesh`): bad files refused with a message naming
//! the file and the place, the springs, masses and pins a mesh makes, free
//! fall, and the GPU against the CPU f32 mirror on the built-in mesh scenes
//! and a generated irregular mesh. GPU tests on lavapipe in CI.

mod common;
mod gpu_common;

use std::path::{Path, PathBuf};

use base64::Engine as _;
use common::{exact_params, noise, run};
use gpu_common::{compare, gpu, worst};
use wgcloth::glam::DVec3;
use wgcloth::gpu::GpuSolver;
use wgcloth::mesh::{Mesh, Placement};
use wgcloth::model::{ClothSpec, Model, Orientation, Pin, Spring, MAX_PARTICLES};
use wgcloth::params::{FilterMethod, FixupMethod, Integrator, Params, SpringKind};
use wgcloth::real::Vec3;
use wgcloth::{Error, Scene};

/// A fresh folder for one test's files.
fn folder(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wgcloth-meshes-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    dir
}

/// An OBJ of an irregular `nx × ny` sheet (1 m square, horizontal, at the
/// origin): rows spaced more and more widely, every vertex nudged by up to
/// a fifth of a cell, and each cell a quad or two triangles (either
/// diagonal) by a fixed hash, so triangle sizes and shapes all differ.
fn irregular_obj(nx: usize, ny: usize) -> String {
    let mut text = String::new();
    for row in 0..ny {
        // Graded rows: spacing grows down the sheet.
        let v = (row as f64 / (ny - 1) as f64).powf(1.5);
        for col in 0..nx {
            let u = col as f64 / (nx - 1) as f64;
            let seed = (row * nx + col) as u64;
            let (du, dv) = (
                0.2 * noise(seed) / nx as f64,
                0.2 * noise(seed + 99) / ny as f64,
            );
            let inner = |t: f64, d: f64| if t > 0.0 && t < 1.0 { t + d } else { t };
            text += &format!("v {} 0 {}\n", inner(u, du), inner(v, dv));
        }
    }
    let id = |row: usize, col: usize| row * nx + col + 1;
    for row in 0..ny - 1 {
        for col in 0..nx - 1 {
            let (a, b) = (id(row, col), id(row, col + 1));
            let (c, d) = (id(row + 1, col), id(row + 1, col + 1));
            let pick = noise((row * nx + col) as u64 + 7);
            text += &if pick < -0.3 {
                format!("f {a} {c} {d} {b}\n")
            } else if pick < 0.35 {
                format!("f {a} {c} {b}\nf {b} {c} {d}\n")
            } else {
                format!("f {a} {c} {d}\nf {a} {d} {b}\n")
            };
        }
    }
    text
}

/// Parses mesh text as the file `name` (its extension gives the format).
fn parse(text: &str, name: &str) -> wgcloth::Result<Mesh> {
    Mesh::parse(text.as_bytes(), Path::new(name), None, &|uri| {
        Err(format!("no external buffer {uri} in this test"))
    })
}

/// A glTF file of one triangle primitive, its buffer (positions as f32,
/// then indices as u32) embedded; `edit` rewrites the JSON for a bad row.
fn gltf(positions: &[[f32; 3]], indices: &[u32], edit: impl Fn(String) -> String) -> String {
    let mut bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let position_bytes = bytes.len();
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let data = base64::engine::general_purpose::STANDARD.encode(&bytes);
    edit(format!(
        r#"{{
  "asset": {{ "version": "2.0" }},
  "meshes": [{{ "name": "sheet", "primitives": [{{ "attributes": {{ "POSITION": 0 }}, "indices": 1 }}] }}],
  "accessors": [
    {{ "bufferView": 0, "componentType": 5126, "count": {}, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1] }},
    {{ "bufferView": 1, "componentType": 5125, "count": {}, "type": "SCALAR" }}
  ],
  "bufferViews": [
    {{ "buffer": 0, "byteOffset": 0, "byteLength": {position_bytes} }},
    {{ "buffer": 0, "byteOffset": {position_bytes}, "byteLength": {} }}
  ],
  "buffers": [{{ "byteLength": {}, "uri": "data:application/octet-stream;base64,{data}" }}]
}}"#,
        positions.len(),
        indices.len(),
        bytes.len() - position_bytes,
        bytes.len()
    ))
}

/// A unit square as two triangles.
const SQUARE: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 0.0, 1.0],
    [0.0, 0.0, 1.0],
];
const SQUARE_INDICES: [u32; 6] = [0, 3, 1, 1, 3, 2];

/// A row of the bad-mesh table: the mesh file, its contents (`None`: not
/// written), `mesh_name`, and what the message must say.
type BadMesh<'a> = (&'a str, Option<String>, Option<&'a str>, &'a [&'a str]);

#[test]
fn bad_meshes_are_refused_naming_the_file_and_the_place() {
    let dir = folder("bad");
    let square = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n";
    let same = |s: String| s;
    let rows: Vec<BadMesh> = vec![
        ("missing.obj", None, None, &["cannot read", "missing.obj"]),
        (
            "syntax.obj",
            Some(format!("{square}v 0 zero 0\n")),
            None,
            &["line 5", "`zero` is not a number"],
        ),
        (
            "range.obj",
            Some(format!("{square}f 1 2 3\nf 1 3 9\n")),
            None,
            &["line 6", "corner 9 is out of range", "1..=4"],
        ),
        (
            "degenerate.obj",
            Some("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n".to_string()),
            None,
            &["line 4", "degenerate face", "zero area"],
        ),
        (
            "repeated.obj",
            Some(format!("{square}f 1 2 2\n")),
            None,
            &["line 5", "degenerate face", "vertex 1 appears twice"],
        ),
        (
            "duplicate.obj",
            Some(format!("{square}f 1 2 3\nf 1 3 4\nf 3 1 2\n")),
            None,
            &["line 5 and line 7", "the same face twice"],
        ),
        (
            "nan.obj",
            Some(format!("{square}v nan 0 0\nf 1 2 3\n")),
            None,
            &["line 5", "finite"],
        ),
        (
            "empty.obj",
            Some(square.to_string()),
            None,
            &["has no faces"],
        ),
        (
            "polygon.obj",
            Some(format!("{square}v 2 0 0\nf 1 2 5 3 4\n")),
            None,
            &["line 6", "3 or 4 corners"],
        ),
        (
            "nonmanifold.obj",
            Some(format!("{square}v 0 1 0\nf 1 2 3\nf 1 3 4\nf 1 3 5\n")),
            None,
            &[
                "non-manifold edge",
                "vertices 0 and 2",
                "3 faces",
                "line 6, line 7, line 8",
            ],
        ),
        (
            "isolated.obj",
            Some(format!("{square}v 5 5 5\nf 1 2 3\nf 1 3 4\n")),
            None,
            &["vertex 4", "in no face"],
        ),
        (
            "statement.obj",
            Some(format!("{square}curv 0 1 1 2\n")),
            None,
            &["line 5", "unknown statement `curv`"],
        ),
        (
            "mesh.ply",
            Some(square.to_string()),
            None,
            &["unknown mesh format `ply`", ".obj", ".gltf", ".glb"],
        ),
        (
            "syntax.gltf",
            Some("{\n  \"asset\": {\n}".to_string()),
            None,
            &["line 3, column 1", "not valid glTF JSON"],
        ),
        (
            "validation.gltf",
            Some(gltf(&SQUARE, &SQUARE_INDICES, |s| {
                s.replace("\"bufferView\": 1,", "\"bufferView\": 7,")
            })),
            None,
            &["`accessors[1].bufferView`"],
        ),
        (
            "range.gltf",
            Some(gltf(&SQUARE, &[0, 3, 1, 1, 3, 4], same)),
            None,
            &[
                "meshes[0].primitives[0].indices`, triangle 1",
                "index 4 is out of range",
            ],
        ),
        (
            "degenerate.gltf",
            Some(gltf(&SQUARE, &[0, 3, 1, 1, 1, 2], same)),
            None,
            &[
                "meshes[0].primitives[0], triangle 1",
                "vertex 1 appears twice",
            ],
        ),
        (
            "duplicate.gltf",
            Some(gltf(&SQUARE, &[0, 3, 1, 3, 1, 0], same)),
            None,
            &["triangle 0 and", "triangle 1", "the same face twice"],
        ),
        (
            "nan.gltf",
            Some(gltf(
                &[[0.0; 3], [1.0, 0.0, 0.0], [f32::NAN, 0.0, 1.0]],
                &[0, 2, 1],
                same,
            )),
            None,
            &["`accessors[0]`: vertex 2", "finite"],
        ),
        (
            "lines.gltf",
            Some(gltf(&SQUARE, &SQUARE_INDICES, |s| {
                s.replace("\"indices\": 1", "\"indices\": 1, \"mode\": 1")
            })),
            None,
            &["no primitive of mode 4"],
        ),
        (
            "short.gltf",
            Some(gltf(&SQUARE, &SQUARE_INDICES, |s| {
                s.replace("\"count\": 6", "\"count\": 9")
            })),
            None,
            &["`accessors[1]`", "do not fit bufferView 1"],
        ),
        (
            "huge.gltf",
            Some(gltf(&SQUARE, &SQUARE_INDICES, |s| {
                s.replace("\"count\": 4", &format!("\"count\": {}", MAX_PARTICLES + 1))
            })),
            None,
            &[
                "`accessors[0]` (POSITION)",
                "16777217 vertices",
                "at most 16777216 particles",
            ],
        ),
        (
            "folder.obj",
            None,
            None,
            &["folder.obj is not a regular file"],
        ),
        (
            "named.obj",
            Some(format!("{square}f 1 2 3\n")),
            Some("sheet"),
            &["`cloth.mesh_name` picks a mesh of a glTF file"],
        ),
        (
            "named.gltf",
            Some(gltf(&SQUARE, &SQUARE_INDICES, same)),
            Some("sail"),
            &["no mesh named `sail`", "`sheet`"],
        ),
    ];
    std::fs::create_dir(dir.join("folder.obj")).expect("a folder");
    let mut failures = Vec::new();
    for (file, contents, mesh_name, needles) in rows {
        let mesh_path = dir.join(file);
        if let Some(text) = &contents {
            std::fs::write(&mesh_path, text).expect("write the mesh");
        }
        let name_key = mesh_name.map_or(String::new(), |n| format!("mesh_name = \"{n}\"\n"));
        let scene = dir.join(format!("{file}.toml"));
        std::fs::write(&scene, format!("[cloth]\nmesh = \"{file}\"\n{name_key}"))
            .expect("write the scene");
        match Scene::load(&scene) {
            Err(e @ Error::Mesh { .. }) => {
                let message = e.to_string();
                let Error::Mesh { path, .. } = &e else {
                    unreachable!()
                };
                let missing: Vec<&&str> =
                    needles.iter().filter(|n| !message.contains(**n)).collect();
                if path != &mesh_path || !missing.is_empty() {
                    failures.push(format!("{file}: {message} (missing {missing:?})"));
                }
                eprintln!("{file}: {message}");
            }
            other => failures.push(format!("{file}: expected a mesh error, got {other:?}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_mesh_beyond_the_device_limits_is_refused_naming_the_limit() {
    let (device, queue) = gpu_common::small_device();
    let params = Params::default();
    let mesh = parse(&irregular_obj(129, 129), "large.obj").expect("a valid mesh");
    let model = mesh
        .model(PLACED, 0.3, &[], &params.springs)
        .expect("a valid model");
    match GpuSolver::new(&device, &queue, &model, &params) {
        Err(e @ Error::DeviceLimit { .. }) => {
            assert!(
                e.to_string().contains("max_storage_buffer_binding_size"),
                "{e}"
            );
        }
        Err(e) => panic!("expected a device-limit error, got {e}"),
        Ok(_) => panic!("a 129 × 129 mesh fitted a 1 MiB binding"),
    }
}

/// The generated sheets' place: 1 m up, centred over the origin like
/// [`gpu_common::busy_params`]'s ground and sphere expect.
const PLACED: Placement = Placement {
    scale: 1.0,
    origin: DVec3::new(-0.5, 1.0, -0.5),
};

/// An OBJ quad grid: the rest positions of a grid cloth written with
/// enough digits to read back exactly, row by row, each cell a quad.
fn quad_grid_obj(spec: &ClothSpec) -> String {
    let mut text = String::new();
    for p in 0..spec.particle_count() {
        let [x, y, z] = spec.rest_position(p).to_array();
        text += &format!("v {x:?} {y:?} {z:?}\n");
    }
    let id = |row: usize, col: usize| row * spec.nx + col + 1;
    for row in 0..spec.ny - 1 {
        for col in 0..spec.nx - 1 {
            let (a, b, c, d) = (
                id(row, col),
                id(row, col + 1),
                id(row + 1, col),
                id(row + 1, col + 1),
            );
            text += &format!("f {a} {c} {d} {b}\n");
        }
    }
    text
}

/// A model's springs of `kind` as a sorted set of (pair, rest length bits).
fn spring_set(model: &Model, kind: SpringKind) -> Vec<((u32, u32), u64)> {
    let mut set: Vec<_> = model.springs[model.kind_ranges[kind.index()].clone()]
        .iter()
        .map(|s: &Spring| ((s.i.min(s.j), s.i.max(s.j)), s.rest.to_bits()))
        .collect();
    set.sort_unstable();
    set
}

#[test]
fn an_obj_quad_grid_reproduces_the_grid_springs() {
    let params = Params::default();
    for orientation in [Orientation::Horizontal, Orientation::Vertical] {
        let spec = ClothSpec {
            nx: 7,
            ny: 5,
            size: [1.3, 0.7],
            origin: DVec3::new(-0.4, 1.1, 0.2),
            orientation,
            pins: vec![],
            ..ClothSpec::default()
        };
        let grid = Model::new(&spec, &params.springs).expect("a valid grid");
        let mesh = parse(&quad_grid_obj(&spec), "grid.obj").expect("a valid mesh");
        let placement = Placement {
            scale: 1.0,
            origin: DVec3::ZERO,
        };
        let from_mesh = mesh
            .model(placement, spec.mass, &[], &params.springs)
            .expect("a valid model");
        assert_eq!(from_mesh.rest_positions, grid.rest_positions);
        // Stretch and shear exactly (the issue's contract); bend too, as a
        // quad grid's bending is the grid's two-apart springs.
        for kind in SpringKind::ALL {
            let (g, m) = (spring_set(&grid, kind), spring_set(&from_mesh, kind));
            assert!(!g.is_empty(), "{kind:?}: the grid has none");
            assert_eq!(g, m, "{orientation:?} {kind:?} springs differ");
        }
        // A quad is drawn as two triangles, as a grid cell is.
        assert_eq!(from_mesh.triangles.len(), grid.triangles.len());
    }
}

/// Lumped masses are sums of a few hundred area thirds divided by the
/// total: rounding is ~1e-16 relative per term, so 1e-12 of the total is
/// far above it and far below any lost or doubled triangle.
const MASS_SUM_TOL: f64 = 1e-12;

#[test]
fn lumped_masses_add_up_to_the_mass_in_proportion_to_area() {
    let params = Params::default();
    let mut models = Vec::new();
    for name in ["tablecloth", "banner"] {
        let scene = Scene::builtin(name).expect("built in");
        models.push((
            name,
            scene.cloths[0].spec.mass,
            scene.model().expect("valid"),
        ));
    }
    let mesh = parse(&irregular_obj(9, 7), "sheet.obj").expect("a valid mesh");
    let sheet = mesh
        .model(PLACED, 0.3, &[], &params.springs)
        .expect("a valid model");
    models.push(("irregular", 0.3, sheet));
    for (name, mass, model) in &models {
        let sum: f64 = model.mass.iter().sum();
        assert!(
            (sum - mass).abs() <= MASS_SUM_TOL * mass,
            "{name}: masses add up to {sum} kg, expected {mass} kg"
        );
        // Irregular meshes give unequal shares (the test is not of a
        // uniform split).
        let (lo, hi) = model
            .mass
            .iter()
            .fold((f64::MAX, 0.0f64), |(lo, hi), &m| (lo.min(m), hi.max(m)));
        assert!(hi > 1.5 * lo, "{name}: masses from {lo} to {hi} kg");
    }
    // Proportional to the lumped area: a vertex's share is a third of its
    // triangles' area over the total.
    let (_, mass, model) = &models[2];
    let area = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|p| Vec3::<f64>::from_f64(model.rest_positions[p as usize]));
        0.5 * (b - a).cross(c - a).length()
    };
    let total: f64 = model.triangles.iter().map(area).sum();
    for p in [0, 10, 40] {
        let mine: f64 = model
            .triangles
            .iter()
            .filter(|t| t.contains(&(p as u32)))
            .map(area)
            .sum();
        let expected = mass * mine / 3.0 / total;
        assert!(
            (model.mass[p] - expected).abs() <= MASS_SUM_TOL * mass,
            "particle {p}: {} kg, expected {expected} kg",
            model.mass[p]
        );
    }
}

#[test]
fn region_pins_pin_exactly_the_particles_inside_the_box() {
    let params = Params::default();
    // A grid: the box around the top row (row 0 at z = origin z) of a
    // horizontal 6 × 4 cloth pins exactly that row.
    let spec = ClothSpec {
        nx: 6,
        ny: 4,
        size: [1.0, 0.6],
        origin: DVec3::new(-0.5, 1.0, -0.3),
        pins: vec![Pin::Region([
            DVec3::new(-0.6, 0.9, -0.31),
            DVec3::new(0.6, 1.1, -0.29),
        ])],
        ..ClothSpec::default()
    };
    let grid = Model::new(&spec, &params.springs).expect("valid");
    let expected: Vec<bool> = (0..24).map(|p| p < 6).collect();
    assert_eq!(grid.pinned, expected);
    // Bounds are included: a flat box exactly through row 0 (y = 1,
    // z = −0.3) pins it too.
    let flat = ClothSpec {
        pins: vec![Pin::Region([
            DVec3::new(-1.0, 1.0, -0.3),
            DVec3::new(1.0, 1.0, -0.3),
        ])],
        ..spec.clone()
    };
    let grid = Model::new(&flat, &params.springs).expect("valid");
    assert_eq!(grid.pinned, expected);
    // A mesh: a box over a corner of the irregular sheet pins the vertices
    // whose placed position is inside, which are neither none nor all.
    let mesh = parse(&irregular_obj(9, 7), "sheet.obj").expect("a valid mesh");
    let bounds = [DVec3::new(-0.55, 0.99, -0.55), DVec3::new(-0.2, 1.01, -0.1)];
    let model = mesh
        .model(PLACED, 0.3, &[Pin::Region(bounds)], &params.springs)
        .expect("valid");
    let inside = |x: &[f64; 3]| (0..3).all(|k| bounds[0][k] <= x[k] && x[k] <= bounds[1][k]);
    let placed: Vec<[f64; 3]> = mesh
        .positions
        .iter()
        .map(|p| [0, 1, 2].map(|k| PLACED.origin[k] + p[k]))
        .collect();
    let expected: Vec<bool> = placed.iter().map(inside).collect();
    assert_eq!(model.pinned, expected);
    let count = expected.iter().filter(|p| **p).count();
    assert!(count > 2 && count < placed.len() / 4, "{count} pinned");
    // They hold under gravity while the rest falls.
    let mut p = exact_params(Integrator::Implicit, 1.0 / 120.0);
    p.implicit.tolerance = 1e-6;
    let s = run::<f64>(&model, &p, 20);
    for (k, x) in s.positions().iter().enumerate() {
        let moved = (*x - model.rest_positions[k]).length();
        assert_eq!(
            moved == 0.0,
            model.pinned[k],
            "particle {k} moved {moved} m"
        );
    }
}

/// Free fall in `f64` (as `tests/cpu_physics.rs`): rounding in `x += dt v`
/// over 200 steps plus the implicit CG to 1e-12, far below 1e-10 m; any
/// modelling error (a wrong mass, a stray force) is far above.
const FREE_FALL_TOL: f64 = 1e-10;
/// The same in `f32` on the GPU: 200 additions to ~1 m positions, each
/// rounded by at most half an ulp (6e-8 m), stay below 1.2e-5 m; 5e-5 m
/// leaves margin, while one step too many or too few is 2e-3 m off.
const GPU_FREE_FALL_TOL: f64 = 5e-5;
/// CG iterations the GPU free fall may record per step (it needs one).
const GPU_CG_ITERATIONS: u32 = 8;

#[test]
fn free_fall_on_a_mesh_matches_the_exact_discrete_solution() {
    let steps = 200u32;
    let dt = 1e-3;
    let mesh = parse(&irregular_obj(9, 7), "sheet.obj").expect("a valid mesh");
    let ctx = gpu();
    for integrator in Integrator::ALL {
        let mut params = exact_params(integrator, dt);
        for spring in &mut params.springs {
            spring.stiffness = 0.0;
        }
        let model = mesh
            .model(PLACED, 0.3, &[], &params.springs)
            .expect("valid");
        assert!(model.springs.is_empty(), "every spring kind is off");
        // v_n = n dt g, x_n = x_0 + dt² g n(n+1)/2.
        let n = f64::from(steps);
        let drop = params.gravity[1] * dt * dt * n * (n + 1.0) / 2.0;
        let expected: Vec<Vec3<f64>> = model
            .rest_positions
            .iter()
            .map(|x0| Vec3::new(x0[0], x0[1] + drop, x0[2]))
            .collect();
        let cpu = run::<f64>(&model, &params, u64::from(steps));
        let (d, p) = common::max_distance(&cpu.positions(), &expected);
        assert!(
            d < FREE_FALL_TOL,
            "{integrator} CPU: particle {p} off by {d:e} m"
        );
        // A cloth without springs binds empty spring arrays: the GPU
        // solver must take it as the CPU does. Without springs the implicit
        // matrix is the mass matrix, which the block-Jacobi preconditioner
        // inverts exactly: CG converges in one iteration, so a budget of
        // GPU_CG_ITERATIONS spares recording thousands of empty ones.
        let mut on_gpu = params.clone();
        on_gpu.implicit.max_iterations = GPU_CG_ITERATIONS;
        let mut g = GpuSolver::new(&ctx.device, &ctx.queue, &model, &on_gpu).expect("GPU solver");
        g.step(steps).expect("GPU run");
        let state = g.read_state().expect("read-back");
        let (d, p) = common::max_distance(&state.x, &expected);
        assert!(
            d < GPU_FREE_FALL_TOL,
            "{integrator} GPU: particle {p} off by {d:e} m"
        );
    }
}

/// One step, GPU against the CPU f32 mirror (as `tests/gpu_scenes.rs`):
/// the same f32 operations in the same order; what may differ is an
/// adapter's freedom to fuse multiply-adds and its division and
/// square-root rounding, a few ulps of ~1 m. On lavapipe the two agree
/// bit for bit (printed below).
const ONE_STEP_TOL: f64 = 1e-6;
/// 200 steps: ulp-level differences feed back through springs, fix-up and
/// CG; 1e-3 m bounds them with a margin and still catches any wrong term
/// (a 1 % error in one force moves these cloths by more within 200 steps).
const MANY_STEP_TOL: f64 = 1e-3;

/// The scalable semi-implicit filter: the GPU solves it by CG to a
/// relative 1e-5 and the CPU exactly (see `docs/design.md`), so even one
/// step differs by ~1e-5 of a step's motion; 1e-5 m bounds that and a
/// wrong filter entry moves the cloth by more.
const SCALABLE_FILTER_TOL: f64 = 1e-5;

/// The explicit step on the meshes \[s\]: well inside the stability
/// bound `√(m/k)` of their smallest cells (the banner's rim: ~2e-4 kg on
/// 200 N/m springs, about 1e-3 s), so 200 steps test agreement, not a
/// blow-up.
const EXPLICIT_DT: f64 = 1e-4;

#[test]
fn gpu_matches_the_cpu_mirror_on_mesh_scenes_and_an_irregular_mesh() {
    let sheet = parse(&irregular_obj(17, 13), "sheet.obj").expect("a valid mesh");
    let mut failures = Vec::new();
    for integrator in Integrator::ALL {
        let mut cases: Vec<(String, Model, Params)> = Vec::new();
        for name in ["tablecloth", "banner"] {
            let mut scene = Scene::builtin(name).expect("built in");
            scene.params.integrator = integrator;
            cases.push((
                name.to_string(),
                scene.model().expect("valid"),
                scene.params,
            ));
        }
        let params = gpu_common::busy_params(integrator);
        let pins = [Pin::Region([
            DVec3::new(-0.6, 0.9, -0.6),
            DVec3::new(0.6, 1.1, -0.45),
        ])];
        let model = sheet
            .model(PLACED, 0.3, &pins, &params.springs)
            .expect("valid");
        if integrator == Integrator::SemiImplicit {
            // The scalable filter: a banded Cholesky factor in the file's
            // vertex order on the CPU, CG on the adjacency on the GPU.
            let mut banded = params.clone();
            banded.semi_implicit.filter = FilterMethod::Banded;
            cases.push(("irregular banded".to_string(), model.clone(), banded));
        }
        cases.push(("irregular".to_string(), model, params));
        for (name, model, mut params) in cases {
            // The GPU's fix-up is Jacobi; explicit needs the small step
            // its stability bound asks for on the meshes' smallest cells.
            params.fixup.method = FixupMethod::Jacobi;
            if integrator == Integrator::Explicit {
                params.dt = params.dt.min(EXPLICIT_DT);
            }
            // An adapter that rounds otherwise than the mirror: each step
            // against the mirror re-seeded before it (free runs part).
            let what = format!("{name} {integrator}");
            let make = || gpu_common::exact_gpu(&model, &params);
            if let Some(verdict) = gpu_common::bounded_steps(&what, make, &model, &params, 200) {
                if let Err(e) = verdict {
                    failures.push(e);
                }
                continue;
            }
            let scalable = params.semi_implicit.filter == FilterMethod::Banded;
            for (steps, tol) in [(1, ONE_STEP_TOL), (200, MANY_STEP_TOL)] {
                let tol = if scalable {
                    tol.max(SCALABLE_FILTER_TOL)
                } else {
                    tol
                };
                let (d, p, g, c) = compare(&model, &params, steps);
                let line = format!(
                    "{name} {integrator} {steps} steps: worst {d:e} m at particle {p} \
                     (GPU {g:?}, CPU {c:?})"
                );
                eprintln!("{line}");
                if d.is_nan() || d >= tol {
                    failures.push(line);
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_mesh_cloth_steps_the_same_on_both_backends_from_a_scene_file() {
    // The whole path a user takes: a scene file naming an OBJ beside it.
    let dir = folder("scene");
    std::fs::write(dir.join("sheet.obj"), irregular_obj(6, 5)).expect("write");
    let scene_path = dir.join("sheet.toml");
    std::fs::write(
        &scene_path,
        "[cloth]\nmesh = \"sheet.obj\"\nscale = 2.0\norigin = [0, 1, 0]\n\
         pins = [0, { box = [[1.9, 0.9, -0.1], [2.1, 1.1, 0.1]] }]\n",
    )
    .expect("write");
    let scene = Scene::load(&scene_path).expect("a valid scene");
    // A mesh's defaults: no pins, the file's own placement.
    std::fs::write(dir.join("bare.toml"), "[cloth]\nmesh = \"sheet.obj\"\n").expect("write");
    let bare = Scene::load(&dir.join("bare.toml")).expect("a valid scene");
    let bare_model = bare.model().expect("valid");
    assert_eq!(bare_model.pinned_count(), 0);
    assert_eq!(bare_model.rest_positions[5], DVec3::new(1.0, 0.0, 0.0));
    let model = scene.model().expect("valid");
    assert_eq!(model.particle_count(), 30);
    // Scaled, then moved: vertex 5 (the first row's last, at x = 1 in the
    // file) is at x = 2, 1 m up.
    assert_eq!(model.rest_positions[5], DVec3::new(2.0, 1.0, 0.0));
    // Vertex 0 by index, vertex 5 by the box.
    assert!(model.pinned[0] && model.pinned[5] && model.pinned_count() == 2);
    let (d, p) = {
        let ctx = gpu();
        let mut g = GpuSolver::new(&ctx.device, &ctx.queue, &model, &scene.params).expect("GPU");
        g.step(10).expect("GPU run");
        let state = g.read_state().expect("read-back");
        let cpu = run::<f32>(&model, &scene.params, 10);
        worst(&state.x, &cpu.positions())
    };
    assert!(d < MANY_STEP_TOL, "worst {d:e} m at particle {p}");
}
