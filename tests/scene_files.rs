//! Scene files through the public API: the built-in scenes, a file with every
//! key, the defaults of partial tables, and one bad file per kind of error.

use std::path::{Path, PathBuf};

use wgcloth::glam::DVec3;
use wgcloth::model::{ClothSpec, Corner, Edge, Orientation, Pin};
use wgcloth::params::{
    ContactMethod, FilterMethod, FixupMethod, FixupParams, Ground, ImplicitParams, Integrator,
    Params, SelfCollision, SemiImplicitParams, Sphere, SpringKind, SpringParams, Wind,
};
use wgcloth::scene::MAX_SCENE_BYTES;
use wgcloth::{Error, Scene};

fn repo_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
}

fn parse(text: &str) -> Scene {
    Scene::from_toml(text, Path::new("test.toml"))
        .unwrap_or_else(|e| panic!("scene should load, got: {e}\n--- text ---\n{text}"))
}

#[test]
fn every_builtin_scene_loads_validates_and_builds() {
    for &name in Scene::builtin_names() {
        let scene = Scene::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(scene.name, name);
        scene.params.validate().expect("params valid");
        match &scene.cloths[0].mesh {
            Some(mesh) => mesh
                .validate(&scene.cloths[0].spec)
                .expect("mesh cloth valid"),
            None => scene.cloths[0].spec.validate().expect("cloth valid"),
        }
        let model = scene.model().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(model.particle_count(), scene.particle_count());
        // The embedded text and the file on disk are the same scene.
        let on_disk = Scene::load(&repo_path(&format!("scenes/{name}.toml"))).expect("loads");
        assert_eq!(on_disk, scene, "{name}: file and built-in differ");
    }
}

#[test]
fn builtin_names_match_the_files_in_scenes() {
    let mut on_disk: Vec<String> = std::fs::read_dir(repo_path("scenes"))
        .expect("scenes/ exists")
        .map(|entry| entry.expect("readable entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| p.file_stem().expect("stem").to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    let mut names: Vec<&str> = Scene::builtin_names().to_vec();
    names.sort_unstable();
    assert_eq!(on_disk, names);
}

#[test]
fn builtin_scenes_are_the_ones_described() {
    let hanging = Scene::builtin("hanging").expect("loads");
    assert_eq!(hanging.params.integrator, Integrator::Explicit);
    assert_eq!(
        (hanging.cloths[0].spec.nx, hanging.cloths[0].spec.ny),
        (33, 33)
    );
    assert_eq!(
        hanging.cloths[0].spec.pins,
        [Pin::Corner(Corner::TopLeft), Pin::Corner(Corner::TopRight)]
    );
    assert_eq!(hanging.cloths[0].spec.origin[1], 1.0);
    assert_eq!(hanging.params.ground.map(|g| g.height), Some(0.0));

    let curtain = Scene::builtin("curtain").expect("loads");
    assert_eq!(curtain.params.integrator, Integrator::Implicit);
    assert_eq!(curtain.cloths[0].spec.orientation, Orientation::Vertical);
    assert_eq!(curtain.cloths[0].spec.pins, [Pin::Edge(Edge::Top)]);

    let flag = Scene::builtin("flag").expect("loads");
    assert_eq!(flag.params.integrator, Integrator::SemiImplicit);
    assert_eq!((flag.cloths[0].spec.nx, flag.cloths[0].spec.ny), (33, 21));
    assert_eq!(flag.cloths[0].spec.pins, [Pin::Edge(Edge::Left)]);
    let wind = flag.params.wind.expect("the flag has wind");
    assert!(wind.velocity[0] > 0.0 && wind.velocity[2] != 0.0);

    let drape = Scene::builtin("drape").expect("loads");
    assert_eq!(drape.params.integrator, Integrator::Implicit);
    assert!(drape.cloths[0].spec.pins.is_empty());
    assert_eq!(drape.params.spheres.len(), 1);
    assert_eq!(drape.params.spheres[0].radius, 0.35);
    assert_eq!(drape.params.spheres[0].center, DVec3::ZERO);
    assert!(drape.params.ground.is_some());
}

const FULL: &str = r#"
[simulation]
integrator = "semi-implicit"
dt = 0.004
gravity = [0.0, -9.0, 0.5]
duration = 7.5

[cloth]
resolution = [17, 9]
size = [2.0, 1.5]
origin = [1.0, 3.0, -2.0]
orientation = "vertical"
mass = 0.8
pins = ["top-left", "right", 20]

[springs.stretch]
stiffness = 400.0
damping = 0.4
max_stretch = 1.05

[springs.shear]
stiffness = 100
damping = 0.1
max_stretch = 1.2

[springs.bend]
stiffness = 0
damping = 0
max_stretch = 1.5

[fixup]
iterations = 25
method = "jacobi"
omega = 1.5

[implicit]
tolerance = 1e-6
max_iterations = 500
coarse_levels = false

[semi_implicit]
filter = "banded"
torque_compensation = false

[ground]
height = -1.0
friction = 0.25

[[sphere]]
center = [0.0, 1.0, 0.0]
radius = 0.5
friction = 0.1

[[sphere]]
center = [1.0, 0.5, 0.0]
radius = 0.25
friction = 0.0

[wind]
velocity = [3.0, 0.0, -1.0]
drag = 0.7
lift = 0.2

[self_collision]
thickness = 0.05
friction = 0.4
iterations = 3
method = "triangles"
"#;

#[test]
fn a_file_with_every_key_gives_exactly_those_values() {
    let scene = Scene::from_toml(FULL, Path::new("dir/full.toml")).expect("loads");
    assert_eq!(scene.name, "full");
    assert_eq!(scene.duration, 7.5);
    // Struct literals without `..Default::default()`: a new field fails to
    // compile here until the format (and this test) covers it.
    let cloth = ClothSpec {
        nx: 17,
        ny: 9,
        size: [2.0, 1.5],
        origin: DVec3::new(1.0, 3.0, -2.0),
        orientation: Orientation::Vertical,
        mass: 0.8,
        pins: vec![
            Pin::Corner(Corner::TopLeft),
            Pin::Edge(Edge::Right),
            Pin::Index(20),
        ],
    };
    let params = Params {
        integrator: Integrator::SemiImplicit,
        dt: 0.004,
        gravity: DVec3::new(0.0, -9.0, 0.5),
        springs: [
            SpringParams {
                stiffness: 400.0,
                damping: 0.4,
                max_stretch: Some(1.05),
            },
            SpringParams {
                stiffness: 100.0,
                damping: 0.1,
                max_stretch: Some(1.2),
            },
            SpringParams {
                stiffness: 0.0,
                damping: 0.0,
                max_stretch: Some(1.5),
            },
        ],
        fixup: FixupParams {
            iterations: 25,
            method: FixupMethod::Jacobi,
            omega: 1.5,
        },
        implicit: ImplicitParams {
            tolerance: 1e-6,
            max_iterations: 500,
            coarse_levels: false,
        },
        semi_implicit: SemiImplicitParams {
            filter: FilterMethod::Banded,
            torque_compensation: false,
        },
        ground: Some(Ground {
            height: -1.0,
            friction: 0.25,
        }),
        spheres: vec![
            Sphere {
                center: DVec3::new(0.0, 1.0, 0.0),
                radius: 0.5,
                friction: 0.1,
                velocity: DVec3::ZERO,
            },
            Sphere {
                center: DVec3::new(1.0, 0.5, 0.0),
                radius: 0.25,
                friction: 0.0,
                velocity: DVec3::ZERO,
            },
        ],
        capsules: vec![],
        mesh_colliders: vec![],
        wind: Some(Wind {
            velocity: DVec3::new(3.0, 0.0, -1.0),
            drag: 0.7,
            lift: 0.2,
        }),
        self_collision: Some(SelfCollision {
            thickness: Some(0.05),
            friction: 0.4,
            iterations: 3,
            method: ContactMethod::Triangles,
        }),
    };
    assert_eq!(scene.cloths[0].spec, cloth);
    assert_eq!(scene.params, params);
    scene.model().expect("builds");
}

#[test]
fn an_empty_file_is_the_library_defaults() {
    let scene = parse("");
    assert_eq!(scene.cloths[0].spec, ClothSpec::default());
    assert_eq!(scene.params, Params::default());
    assert_eq!(scene.duration, 2.0);
}

#[test]
fn a_partial_table_keeps_the_defaults_of_its_own_kind() {
    let defaults = Params::default();
    let scene = parse("[springs.bend]\nstiffness = 9\n[springs.stretch]\ndamping = 1\n");
    let bend = scene.params.spring(SpringKind::Bend);
    let bend_default = defaults.spring(SpringKind::Bend);
    assert_eq!(bend.stiffness, 9.0);
    assert_eq!(bend.damping, bend_default.damping);
    assert_eq!(bend.max_stretch, None);
    let stretch = scene.params.spring(SpringKind::Stretch);
    assert_eq!(stretch.damping, 1.0);
    assert_eq!(
        stretch.stiffness,
        defaults.spring(SpringKind::Stretch).stiffness
    );
    assert_eq!(stretch.max_stretch, Some(1.1));
    assert_eq!(
        scene.params.spring(SpringKind::Shear),
        defaults.spring(SpringKind::Shear)
    );
}

#[test]
fn empty_collider_and_wind_tables_take_the_documented_defaults() {
    let scene = parse("[ground]\n[[sphere]]\nradius = 1\n[wind]\nvelocity = [1, 2, 3]\n");
    assert_eq!(
        scene.params.ground,
        Some(Ground {
            height: 0.0,
            friction: 0.5
        })
    );
    assert_eq!(
        scene.params.spheres,
        [Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
            friction: 0.5,
            velocity: DVec3::ZERO,
        }]
    );
    assert_eq!(
        scene.params.wind,
        Some(Wind {
            velocity: DVec3::new(1.0, 2.0, 3.0),
            drag: 0.6,
            lift: 0.0
        })
    );
}

#[test]
fn pins_can_be_emptied_and_fixup_switched_off() {
    let scene = parse("[cloth]\npins = []\n[fixup]\niterations = 0\n");
    assert!(scene.cloths[0].spec.pins.is_empty());
    assert_eq!(scene.params.fixup.iterations, 0);
}

#[test]
fn resolve_prefers_files_then_builtins() {
    let path = repo_path("scenes/flag.toml");
    let by_path = Scene::resolve(path.to_str().expect("utf-8 path")).expect("file loads");
    assert_eq!(by_path, Scene::builtin("flag").expect("builtin"));
    assert_eq!(Scene::resolve("drape").expect("builtin").name, "drape");

    let err = Scene::resolve("no-such-scene.toml").expect_err("missing file");
    let message = err.to_string();
    assert!(
        matches!(err, Error::Scene { .. }) && message.contains("cannot read the file"),
        "a missing .toml must be reported as a missing file, got: {message}"
    );

    // A directory that is not a built-in name is refused as what it is.
    let scenes_dir = repo_path("scenes");
    let err = Scene::resolve(scenes_dir.to_str().expect("utf-8 path")).expect_err("a directory");
    assert!(
        matches!(err, Error::Scene { .. }) && err.to_string().contains("is a directory"),
        "{err}"
    );

    let err = Scene::resolve("no-such-scene").expect_err("unknown name");
    let message = err.to_string();
    assert!(matches!(err, Error::UnknownScene { .. }), "{message}");
    for name in Scene::builtin_names() {
        assert!(message.contains(name), "{message} should list `{name}`");
    }
}

/// Where a bad scene comes from.
enum Source {
    /// Parsed by `Scene::from_toml` under the name `bad_scene.toml`.
    Text(&'static str),
    /// A file that does not exist, read by `Scene::load`.
    MissingFile,
    /// A directory named `bad_scene.toml`, given to `Scene::load`.
    Directory,
    /// A file one byte over `MAX_SCENE_BYTES`, given to `Scene::load`.
    Oversized,
}

struct Row {
    what: &'static str,
    source: Source,
    /// Substrings the message must contain besides the file name: the key,
    /// what is allowed, and what was given.
    expect: &'static [&'static str],
}

const fn row(what: &'static str, text: &'static str, expect: &'static [&'static str]) -> Row {
    Row {
        what,
        source: Source::Text(text),
        expect,
    }
}

const BAD_SCENES: &[Row] = &[
    row(
        "unknown top-level table",
        "[simulaton]\ndt = 0.01\n",
        &[
            "`simulaton`",
            "unknown key",
            "`simulation`",
            "`wind`",
            "line 1",
        ],
    ),
    row(
        "unknown key inside a table",
        "[springs.stretch]\nstifness = 5\n",
        &[
            "`springs.stretch.stifness`",
            "`stiffness`",
            "`max_stretch`",
            "line 2",
        ],
    ),
    row(
        "unknown spring kind",
        "[springs.strech]\nstiffness = 5\n",
        &["`springs.strech`", "`stretch`", "`shear`", "`bend`"],
    ),
    row(
        "unknown key in the second sphere",
        "[[sphere]]\nradius = 1\n[[sphere]]\nradus = 1\n",
        &["`sphere[1].radus`", "`radius`", "line 4"],
    ),
    row(
        "wrong type",
        "[simulation]\ndt = \"fast\"\n",
        &[
            "`simulation.dt`",
            "invalid type",
            "\"fast\"",
            "seconds",
            "line 2",
        ],
    ),
    row(
        "wrong type for a flag",
        "[semi_implicit]\ntorque_compensation = 1\n",
        &["`semi_implicit.torque_compensation`", "true or false"],
    ),
    row(
        "array too short",
        "[simulation]\ngravity = [0, -9.8]\n",
        &[
            "`simulation.gravity`",
            "expected exactly 3 numbers, got 2",
            "m/s²",
        ],
    ),
    row(
        "extra resolution",
        "[cloth]\nresolution = [5, 5, 5]\n",
        &[
            "`cloth.resolution`",
            "expected exactly 2 whole numbers, got 3",
            "[nx, ny]",
            "line 2",
        ],
    ),
    row(
        "extra gravity component",
        "[simulation]\ngravity = [0, -9.8, 0, 0]\n",
        &["`simulation.gravity`", "expected exactly 3 numbers, got 4"],
    ),
    row(
        "extra sphere center component, of another type",
        "[[sphere]]\nradius = 1\ncenter = [0, 0, 0, \"x\"]\n",
        &["`sphere[0].center`", "expected exactly 3 numbers, got 4"],
    ),
    row(
        "extra camera target component",
        "[camera]\ntarget = [0, 0, 0, 1]\n",
        &[
            "`camera.target`",
            "expected exactly 3 numbers, got 4",
            "[x, y, z]",
        ],
    ),
    row(
        "extra cloth size",
        "[cloth]\nsize = [1, 1, 1]\n",
        &["`cloth.size`", "expected exactly 2 numbers, got 3"],
    ),
    row(
        "a single [sphere] table",
        "[sphere]\nradius = 1\n",
        &[
            "`sphere`",
            "a table",
            "array of tables",
            "`[[sphere]]`",
            "line 1",
        ],
    ),
    row(
        "a number for a table",
        "springs = 5\n",
        &["`springs`", "integer `5`", "`[springs.stretch]`", "table"],
    ),
    row(
        "a number for a spring kind",
        "[springs]\nstretch = 4\n",
        &[
            "`springs.stretch`",
            "integer `4`",
            "`[springs.<stretch|shear|bend>]`",
        ],
    ),
    row(
        "an array of tables for a table",
        "[[simulation]]\ndt = 0.01\n",
        &["`simulation`", "an array", "`[simulation]`"],
    ),
    row(
        "a table's keys as an array",
        "camera = [[0, 0, 0], 5]\n",
        &["`camera`", "an array", "`[camera]`"],
    ),
    row(
        "a number for the array of spheres",
        "sphere = 1\n",
        &["`sphere`", "`[[sphere]]`"],
    ),
    row(
        "a fraction for a count",
        "[fixup]\niterations = 2.5\n",
        &["`fixup.iterations`", "2.5", "a whole number ≥ 0"],
    ),
    row(
        "a count beyond what can be held",
        "[implicit]\nmax_iterations = 99999999999\n",
        &["`implicit.max_iterations`", "99999999999", "too large"],
    ),
    row(
        "an array for a flag",
        "[implicit]\ncoarse_levels = []\n",
        &["`implicit.coarse_levels`", "an array", "true or false"],
    ),
    row(
        "infinite mass",
        "[cloth]\nmass = inf\n",
        &["`cloth.mass`", "must be finite", "kg", "got inf"],
    ),
    row(
        "NaN stiffness",
        "[springs.shear]\nstiffness = nan\n",
        &["`springs.shear.stiffness`", "must be finite", "got NaN"],
    ),
    row(
        "a huge number is printed with an exponent",
        "[springs.stretch]\nstiffness = 1e300\n",
        &["`springs.stretch.stiffness`", "got 1e300"],
    ),
    row(
        "a tiny number is printed with an exponent",
        "[camera]\ndistance = -1e-300\n",
        &["`camera.distance`", "got -1e-300"],
    ),
    row(
        "infinite duration",
        "[simulation]\nduration = inf\n",
        &["`simulation.duration`", "must be finite", "got inf"],
    ),
    row(
        "unknown integrator name",
        "[simulation]\nintegrator = \"rk4\"\n",
        &[
            "`simulation.integrator`",
            "`rk4`",
            "`explicit`",
            "`implicit`",
            "`semi-implicit`",
        ],
    ),
    row(
        "unknown fix-up method",
        "[fixup]\nmethod = \"sor\"\n",
        &["`fixup.method`", "`sor`", "`gauss-seidel`", "`jacobi`"],
    ),
    row(
        "unknown orientation",
        "[cloth]\norientation = \"diagonal\"\n",
        &[
            "`cloth.orientation`",
            "`diagonal`",
            "`horizontal`",
            "`vertical`",
        ],
    ),
    row(
        "unknown filter",
        "[semi_implicit]\nfilter = \"sparse\"\n",
        &[
            "`semi_implicit.filter`",
            "`sparse`",
            "`auto`",
            "`dense`",
            "`banded`",
        ],
    ),
    row(
        "unknown pin name",
        "[cloth]\npins = [\"top-left\", \"middle\"]\n",
        &[
            "`cloth.pins[1]`",
            "`middle`",
            "top-right",
            "bottom-left",
            "particle index",
        ],
    ),
    row(
        "negative pin index",
        "[cloth]\npins = [-3]\n",
        &["`cloth.pins[0]`", "-3", "≥ 0"],
    ),
    row(
        "pin index out of range",
        "[cloth]\nresolution = [10, 10]\npins = [5000]\n",
        &["`cloth.pins[0]`", "below 100", "5000"],
    ),
    row(
        "resolution below 2",
        "[cloth]\nresolution = [1, 10]\n",
        &["`cloth.resolution[0]`", "≥ 2", "got 1"],
    ),
    row(
        "negative resolution",
        "[cloth]\nresolution = [8, -4]\n",
        &["`cloth.resolution[1]`", "-4", "whole numbers of particles"],
    ),
    row(
        "negative stiffness",
        "[springs.bend]\nstiffness = -1\n",
        &[
            "`springs.bend.stiffness`",
            "0 ≤ stiffness ≤ 1e9",
            "N/m",
            "got -1",
        ],
    ),
    row(
        "dt = 0",
        "[simulation]\ndt = 0\n",
        &["`simulation.dt`", "0 < dt ≤ 1", "seconds", "got 0"],
    ),
    row(
        "dt negative",
        "[simulation]\ndt = -0.01\n",
        &["`simulation.dt`", "0 < dt ≤ 1", "got -0.01"],
    ),
    row(
        "NaN in gravity",
        "[simulation]\ngravity = [0, nan, 0]\n",
        &["`simulation.gravity", "finite", "NaN"],
    ),
    row(
        "duration = 0",
        "[simulation]\nduration = 0\n",
        &[
            "`simulation.duration`",
            "0 < duration ≤ 1e6",
            "seconds",
            "got 0",
        ],
    ),
    row(
        "max_stretch below 1",
        "[springs.shear]\nmax_stretch = 0.9\n",
        &[
            "`springs.shear.max_stretch`",
            "1 ≤ max_stretch",
            "rest length",
            "got 0.9",
        ],
    ),
    row(
        "negative fix-up iterations",
        "[fixup]\niterations = -1\n",
        &["`fixup.iterations`", "-1", "whole number"],
    ),
    row(
        "omega out of range",
        "[fixup]\nomega = 2\n",
        &["`fixup.omega`", "0 < omega < 2", "got 2"],
    ),
    row(
        "zero CG tolerance",
        "[implicit]\ntolerance = 0\n",
        &["`implicit.tolerance`", "0 < tolerance < 1", "got 0"],
    ),
    row(
        "camera field of view out of range",
        "[camera]\nfov = 200\n",
        &["`camera.fov`", "5 ≤ fov ≤ 150", "degrees", "got 200"],
    ),
    row(
        "camera distance not positive",
        "[camera]\ndistance = -1\n",
        &["`camera.distance`", "> 0", "got -1"],
    ),
    row(
        "unknown camera key",
        "[camera]\nzoom = 2\n",
        &["camera", "zoom", "fov"],
    ),
    row(
        "sphere radius 0",
        "[[sphere]]\nradius = 1\n[[sphere]]\nradius = 0\n",
        &["`sphere[1].radius`", "radius > 0", "(m)", "got 0"],
    ),
    row(
        "sphere radius negative",
        "[[sphere]]\nradius = -0.5\n",
        &["`sphere[0].radius`", "radius > 0", "got -0.5"],
    ),
    row(
        "sphere without radius",
        "[[sphere]]\ncenter = [0, 0, 0]\n",
        &["`sphere[0]`", "missing key `radius`"],
    ),
    row(
        "wind without velocity",
        "[wind]\ndrag = 1\n",
        &["`wind`", "missing key `velocity`"],
    ),
    row(
        "negative ground friction",
        "[ground]\nfriction = -0.1\n",
        &["`ground.friction`", "friction ≥ 0", "got -0.1"],
    ),
    row(
        "mass 0",
        "[cloth]\nmass = 0\n",
        &["`cloth.mass`", "> 0", "kg", "got 0"],
    ),
    row(
        "mass negative",
        "[cloth]\nmass = -1\n",
        &["`cloth.mass`", "> 0", "kg", "got -1"],
    ),
    row(
        "TOML syntax error",
        "[simulation\ndt = 0.01\n",
        &["TOML syntax error", "line 1"],
    ),
    row(
        "duplicate key",
        "[simulation]\ndt = 0.01\ndt = 0.02\n",
        &["TOML syntax error", "duplicate key", "line 3"],
    ),
    // Mesh cloths (the mesh path is relative to the scene's folder, here
    // the crate root where tests run).
    row(
        "resolution beside mesh",
        "[cloth]\nmesh = \"scenes/tablecloth.obj\"\nresolution = [4, 4]\n",
        &[
            "`cloth.resolution` conflicts with `cloth.mesh`",
            "origin",
            "scale",
        ],
    ),
    row(
        "size beside mesh",
        "[cloth]\nmesh = \"scenes/tablecloth.obj\"\nsize = [1, 1]\n",
        &["`cloth.size` conflicts with `cloth.mesh`"],
    ),
    row(
        "orientation beside mesh",
        "[cloth]\nmesh = \"scenes/tablecloth.obj\"\norientation = \"vertical\"\n",
        &["`cloth.orientation` conflicts with `cloth.mesh`"],
    ),
    row(
        "scale without mesh",
        "[cloth]\nscale = 2\n",
        &["`cloth.scale`", "only a mesh cloth"],
    ),
    row(
        "mesh_name without mesh",
        "[cloth]\nmesh_name = \"sail\"\n",
        &["`cloth.mesh_name`", "only a mesh cloth"],
    ),
    row(
        "scale zero",
        "[cloth]\nmesh = \"scenes/tablecloth.obj\"\nscale = 0\n",
        &["`cloth.scale`", "> 0", "got 0"],
    ),
    row(
        "corner pin on a mesh",
        "[cloth]\nmesh = \"scenes/tablecloth.obj\"\npins = [\"top-left\"]\n",
        &[
            "`cloth.pins[0]`",
            "vertex index below 631",
            "corner and edge names are for grid",
        ],
    ),
    row(
        "mesh pin index out of range",
        "[cloth]\nmesh = \"scenes/tablecloth.obj\"\npins = [3, 631]\n",
        &["`cloth.pins[1]`", "vertex index below 631", "got 631"],
    ),
    row(
        "box pinning nothing on a grid",
        "[cloth]\npins = [{ box = [[5, 5, 5], [6, 6, 6]] }]\n",
        // The box as the file writes it, not as the Rust type prints.
        &[
            "`cloth.pins[0]`",
            "at least one particle",
            "{ box = [[5, 5, 5], [6, 6, 6]] }, which holds none",
        ],
    ),
    row(
        "box pinning nothing on a mesh",
        "[cloth]\nmesh = \"scenes/tablecloth.obj\"\npins = [{ box = [[5, 5, 5], [6, 6, 6]] }]\n",
        &["`cloth.pins[0]`", "at least one particle", "holds none"],
    ),
    row(
        "box inside out",
        "[cloth]\npins = [{ box = [[1, 1, 1], [0, 2, 2]] }]\n",
        &[
            "`cloth.pins[0].box`",
            "x0 ≤ x1",
            "got [[1, 1, 1], [0, 2, 2]]",
        ],
    ),
    row(
        "box with a misspelt key",
        "[cloth]\npins = [{ boxx = [[0, 0, 0], [1, 1, 1]] }]\n",
        &["`cloth.pins[0].boxx`", "unknown key `boxx`", "`box`"],
    ),
    row(
        "box of one corner",
        "[cloth]\npins = [{ box = [[0, 0, 0]] }]\n",
        &[
            "`cloth.pins[0].box`",
            "expected exactly 2",
            "got 1",
            "two corners in m",
        ],
    ),
    Row {
        what: "missing file",
        source: Source::MissingFile,
        expect: &["cannot read the file"],
    },
    Row {
        what: "a directory",
        source: Source::Directory,
        expect: &["is a directory, not a scene file"],
    },
    Row {
        what: "a file over the size cap",
        source: Source::Oversized,
        expect: &["larger than 1 MiB"],
    },
];

/// A valid scene padded with comment lines to exactly `len` bytes.
fn scene_of_length(len: u64) -> String {
    let mut text = String::from("[simulation]\ndt = 0.01\n");
    let line = format!("#{}\n", "-".repeat(62));
    while text.len() as u64 + line.len() as u64 <= len {
        text.push_str(&line);
    }
    let rest = usize::try_from(len).expect("small") - text.len();
    if rest > 0 {
        text.push('#');
        text.push_str(&"-".repeat(rest - 1));
    }
    assert_eq!(text.len() as u64, len);
    text
}

#[test]
fn a_scene_file_of_exactly_the_cap_loads() {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("scene_at_the_cap.toml");
    std::fs::write(&path, scene_of_length(MAX_SCENE_BYTES)).expect("write");
    let loaded = Scene::load(&path);
    let _ = std::fs::remove_file(&path);
    assert_eq!(loaded.expect("a file of the cap loads").params.dt, 0.01);
}

#[cfg(unix)]
#[test]
fn a_device_or_fifo_is_refused_without_reading_it() {
    // /dev/zero never ends: reading it would run until memory runs out.
    let err = Scene::load(Path::new("/dev/zero")).expect_err("a device");
    assert!(err.to_string().contains("not a regular file"), "{err}");
}

#[test]
fn bad_scene_files_are_refused_with_a_message_naming_key_and_allowed_values() {
    let tmp = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bad_scenes");
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).expect("create the test directory");
    let path = tmp.join("bad_scene.toml");
    let mut failures = Vec::new();
    for row in BAD_SCENES {
        let result = match row.source {
            Source::Text(text) => Scene::from_toml(text, Path::new("bad_scene.toml")),
            Source::MissingFile => Scene::load(&path),
            Source::Directory => {
                std::fs::create_dir(&path).expect("create the directory");
                let result = Scene::load(&path);
                std::fs::remove_dir(&path).expect("remove the directory");
                result
            }
            Source::Oversized => {
                std::fs::write(&path, scene_of_length(MAX_SCENE_BYTES + 1)).expect("write");
                let result = Scene::load(&path);
                std::fs::remove_file(&path).expect("remove the file");
                result
            }
        };
        let err = match result {
            Ok(scene) => {
                failures.push(format!(
                    "{}: loaded, should have failed: {scene:?}",
                    row.what
                ));
                continue;
            }
            Err(err) => err,
        };
        let message = err.to_string();
        if !matches!(err, Error::Scene { .. }) {
            failures.push(format!("{}: not Error::Scene: {message}", row.what));
        }
        let absent: Vec<&str> = std::iter::once("bad_scene.toml")
            .chain(row.expect.iter().copied())
            .filter(|s| !message.contains(s))
            .collect();
        if !absent.is_empty() {
            failures.push(format!(
                "{}: message lacks {absent:?}\n    message: {message}",
                row.what
            ));
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        BAD_SCENES.len(),
        failures.join("\n")
    );
}

/// Every key of the format, by table (`[[sphere]]` needs its radius).
const KEYS: &[(&str, &[&str])] = &[
    ("[simulation]", &["integrator", "dt", "gravity", "duration"]),
    (
        "[cloth]",
        &[
            "resolution",
            "size",
            "origin",
            "orientation",
            "mass",
            "pins",
            "color",
        ],
    ),
    (
        "[[seam]]\na = { edge = \"left\" }\nb = { edge = \"right\" }",
        &["stiffness", "damping", "a", "b"],
    ),
    (
        "[springs.stretch]",
        &["stiffness", "damping", "max_stretch"],
    ),
    ("[fixup]", &["iterations", "method", "omega"]),
    (
        "[implicit]",
        &["tolerance", "max_iterations", "coarse_levels"],
    ),
    ("[semi_implicit]", &["filter", "torque_compensation"]),
    ("[ground]", &["height", "friction"]),
    ("[[sphere]]\nradius = 1", &["center", "friction"]),
    ("[wind]\nvelocity = [1, 0, 0]", &["drag", "lift"]),
    (
        "[camera]",
        &["target", "distance", "elevation", "azimuth", "fov"],
    ),
];

/// Values that no key accepts: a string no key takes, an inline table, a
/// date, an array of arrays, and an array of four of mixed types.
const WRONG_VALUES: &[&str] = &[
    "\"text\"",
    "{ a = 1 }",
    "1979-05-27",
    "[[1]]",
    "[true, 1, 2, 3]",
];

/// The tables, each given every wrong shape a table can take.
const TABLES: &[&str] = &[
    "simulation",
    "cloth",
    "springs",
    "fixup",
    "implicit",
    "semi_implicit",
    "ground",
    "sphere",
    "seam",
    "wind",
    "camera",
];

/// Words of serde's and Rust's vocabulary that a user of a TOML file does
/// not speak: the TOML words are table, array, integer, string, boolean.
const RUST_WORDS: &[&str] = &[
    "sequence", "struct", "map", "f64", "f32", "u32", "u64", "usize", "i64", "Vec", "Option",
    "Some", "None", "enum", "variant", "tuple",
];

/// A word with an upper-case letter after a lower-case one (`SpringsTable`,
/// `PinEntry`): a Rust type name. `NaN` and `MiB` are how numbers and sizes
/// are written.
fn is_camel_case(word: &str) -> bool {
    let chars: Vec<char> = word.chars().collect();
    !["NaN", "MiB", "KiB"].contains(&word)
        && chars
            .windows(2)
            .any(|w| w[0].is_lowercase() && w[1].is_uppercase())
}

#[test]
fn no_message_for_a_wrong_shape_names_a_rust_type() {
    let mut texts = Vec::new();
    for (header, keys) in KEYS {
        for key in *keys {
            for value in WRONG_VALUES {
                texts.push(format!("{header}\n{key} = {value}\n"));
            }
        }
    }
    for table in TABLES {
        for shape in ["5", "\"text\"", "[]", "[1, 2]", "[[1]]", "true"] {
            // No spheres (seams) at all is a valid `sphere` (`seam`).
            if !(["sphere", "seam"].contains(table) && shape == "[]") {
                texts.push(format!("{table} = {shape}\n"));
            }
        }
        // The other bracket count: `[[camera]]` for a table, `[sphere]` for
        // the array of tables (`cloth` takes both: one cloth, or a world).
        if *table == "sphere" {
            texts.push("[sphere]\nradius = 1\n".to_string());
        } else if *table == "seam" {
            texts.push("[seam]\nstiffness = 1\n".to_string());
        } else if *table != "cloth" {
            texts.push(format!("[[{table}]]\n"));
        }
    }
    texts.push("[springs]\nstretch = 5\n".to_string());
    texts.push("[cloth]\npins = [\"top\", [1]]\n".to_string());
    texts.push("[cloth]\nresolution = [5, 5, 5]\n".to_string());
    texts.push("[fixup]\niterations = -3\n".to_string());

    let mut failures = Vec::new();
    for text in &texts {
        let message = match Scene::from_toml(text, Path::new("shape.toml")) {
            Ok(_) => {
                failures.push(format!("loaded, should have failed:\n{text}"));
                continue;
            }
            Err(e) => e.to_string(),
        };
        let rust: Vec<&str> = message
            .split(|c: char| !(c.is_alphanumeric() || c == '_'))
            .filter(|w| RUST_WORDS.contains(w) || is_camel_case(w))
            .collect();
        if !rust.is_empty() {
            failures.push(format!("{rust:?} in: {message}\n--- text ---\n{text}"));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} wrong shapes:\n{}",
        failures.len(),
        texts.len(),
        failures.join("\n")
    );
}
