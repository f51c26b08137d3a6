//! Fault rows: messages. A bad command line or scene file is refused with
//! exit status 2 and a message that names the option or key and what is
//! allowed, before anything is written: each row runs the binary in a fresh
//! directory (outputs named relative to it) and checks that the directory
//! holds afterwards exactly what it held before.

use std::path::Path;
use std::process::{Command, Output};

use wgcloth::scene::MAX_SCENE_BYTES;

use crate::cli_common::{assert_status, stderr, stdout, TempDir, BIN, EXIT_INVALID};
use crate::refusal_faults;

/// What `scene.toml` in the row's directory is.
enum Scene {
    /// No file: the row runs a built-in scene.
    None,
    /// A file with this text.
    Text(&'static str),
    /// A directory.
    Directory,
    /// A symlink to `/dev/zero`, which never ends.
    DevZero,
    /// A FIFO nobody writes to: opening it would block.
    Fifo,
    /// A valid scene padded to one byte over `MAX_SCENE_BYTES`.
    Oversized,
}

struct Row {
    what: &'static str,
    scene: Scene,
    /// The command line, run in the row's directory.
    args: &'static [&'static str],
    /// What the message must contain: the option or key, what is allowed.
    expect: &'static [&'static str],
    /// What it must not contain.
    absent: &'static [&'static str],
}

/// Every run writes its outputs into its directory, so that a refusal that
/// still wrote something shows up there.
const RUN_OUT: [&str; 4] = [
    "--positions-out",
    "positions.txt",
    "--trace-out",
    "trace.csv",
];

/// A number printed digit by digit instead of with an exponent.
const DIGIT_RUN: &str = "00000000";

/// Rust's and serde's words for TOML's table and array, and a Rust type.
const RUST_WORDS: [&str; 4] = ["sequence", "struct", "map,", "Table"];

const ROWS: &[Row] = &[
    Row {
        what: "--fps above 1/dt in render (a frame shorter than a step)",
        scene: Scene::None,
        args: &["render", "hanging", "--fps", "2000", "--out", "frames"],
        expect: &["--fps", "at most 1/dt = 1000 frames per second", "got 2000"],
        absent: &[],
    },
    Row {
        what: "--fps above 1/dt in run, for a character",
        scene: Scene::None,
        args: &["run", "cape", "--fps", "500"],
        expect: &["--fps", "at most 1/dt = 240 frames per second", "got 500"],
        absent: &[],
    },
    Row {
        what: "--fps for a scene without a character",
        scene: Scene::None,
        args: &["run", "hanging", "--fps", "30"],
        expect: &[
            "--fps only applies to a scene with a [character]",
            "`hanging`",
        ],
        absent: &[],
    },
    Row {
        what: "bench --out naming a file",
        scene: Scene::Text("[simulation]\n"),
        args: &["bench", "stability", "--quick", "--out", "scene.toml"],
        expect: &[
            "--out scene.toml: is a file, not a folder",
            "choose a folder",
        ],
        absent: &["File exists"],
    },
    Row {
        what: "bench --out inside a file",
        scene: Scene::Text("[simulation]\n"),
        args: &["bench", "accuracy", "--quick", "--out", "scene.toml/bench"],
        expect: &["--out scene.toml/bench: is inside scene.toml, which is a file, not a folder"],
        absent: &["Not a directory"],
    },
    Row {
        what: "negative --steps",
        scene: Scene::None,
        args: &["run", "hanging", "--steps", "-5"],
        expect: &["'-5'", "--steps", "whole number of steps", "0 ≤ N ≤ 1e12"],
        absent: &["unexpected argument"],
    },
    Row {
        what: "fractional --steps",
        scene: Scene::None,
        args: &["run", "hanging", "--steps", "2.5"],
        expect: &["--steps", "whole number of steps"],
        absent: &[],
    },
    Row {
        what: "--steps over the cap --seconds has",
        scene: Scene::None,
        args: &["run", "hanging", "--steps", "1000000000001"],
        expect: &["--steps", "0 ≤ N ≤ 1e12", "--seconds"],
        absent: &[],
    },
    Row {
        what: "--seconds over the same cap",
        scene: Scene::None,
        args: &["run", "hanging", "--dt", "1", "--seconds", "1e13"],
        expect: &["--seconds", "1e13 steps", "at most 1e12"],
        absent: &[DIGIT_RUN],
    },
    Row {
        what: "negative --trace-every",
        scene: Scene::None,
        args: &["run", "hanging", "--trace-every", "-1"],
        expect: &["'-1'", "--trace-every", "whole number of steps ≥ 1"],
        absent: &["unexpected argument"],
    },
    Row {
        what: "negative --frames",
        scene: Scene::None,
        args: &["render", "hanging", "--out", "frames", "--frames", "-1"],
        expect: &["'-1'", "--frames", "whole number of frames, 1 ≤ N"],
        absent: &["unexpected argument"],
    },
    Row {
        what: "render --frames 0",
        scene: Scene::None,
        args: &["render", "hanging", "--out", "frames", "--frames", "0"],
        expect: &["--frames", "1 ≤ N", "0 frames would write nothing"],
        absent: &[],
    },
    Row {
        what: "negative --size",
        scene: Scene::None,
        args: &["render", "hanging", "--out", "frames", "--size", "-640x480"],
        expect: &["--size", "`-640`", "whole number of pixels ≥ 1"],
        absent: &["unexpected argument"],
    },
    Row {
        what: "negative --fps with an exponent",
        scene: Scene::None,
        args: &["render", "hanging", "--out", "frames", "--fps", "-1e-300"],
        expect: &["--fps", "finite number > 0", "got -1e-300"],
        absent: &["unexpected argument", DIGIT_RUN],
    },
    Row {
        what: "a tiny --fps is printed with an exponent",
        scene: Scene::None,
        args: &["render", "hanging", "--out", "frames", "--fps", "1e-300"],
        expect: &["fps", "steps per frame", "got 1e-300"],
        absent: &[DIGIT_RUN],
    },
    Row {
        what: "a tiny --dt is printed with an exponent",
        scene: Scene::None,
        args: &["run", "hanging", "--dt", "1e-300", "--seconds", "1"],
        expect: &["--seconds", "dt = 1e-300 s", "at most 1e12"],
        absent: &[DIGIT_RUN],
    },
    Row {
        what: "a negative --dt with an exponent",
        scene: Scene::None,
        args: &["run", "hanging", "--dt", "-1e-300"],
        expect: &["`simulation.dt`", "0 < dt ≤ 1", "got -1e-300"],
        absent: &["unexpected argument", DIGIT_RUN],
    },
    Row {
        what: "[sphere] for [[sphere]]",
        scene: Scene::Text("[sphere]\nradius = 0.2\n"),
        args: &["run", "scene.toml"],
        expect: &[
            "scene.toml",
            "line 1",
            "`sphere`",
            "`[[sphere]]`",
            "array of tables",
        ],
        absent: &RUST_WORDS,
    },
    Row {
        what: "a number for the springs table",
        scene: Scene::Text("springs = 5\n"),
        args: &["run", "scene.toml"],
        expect: &[
            "scene.toml",
            "`springs`",
            "integer `5`",
            "`[springs.stretch]`",
        ],
        absent: &RUST_WORDS,
    },
    Row {
        what: "a number for [cloth]",
        scene: Scene::Text("cloth = 5\n"),
        args: &["run", "scene.toml"],
        expect: &["scene.toml", "`cloth`", "`[cloth]`", "`[[cloth]]`"],
        absent: &RUST_WORDS,
    },
    Row {
        what: "three numbers for the resolution",
        scene: Scene::Text("[cloth]\nresolution = [5, 5, 5]\n"),
        args: &["run", "scene.toml"],
        expect: &[
            "scene.toml",
            "`cloth.resolution`",
            "expected exactly 2 whole numbers, got 3",
        ],
        absent: &RUST_WORDS,
    },
    Row {
        what: "four numbers for a sphere's center",
        scene: Scene::Text("[[sphere]]\ncenter = [0, 0, 0, 1]\nradius = 0.2\n"),
        args: &["run", "scene.toml"],
        expect: &["`sphere[0].center`", "expected exactly 3 numbers, got 4"],
        absent: &RUST_WORDS,
    },
    Row {
        what: "four numbers for gravity",
        scene: Scene::Text("[simulation]\ngravity = [0, -9.81, 0, 0]\n"),
        args: &["run", "scene.toml"],
        expect: &["`simulation.gravity`", "expected exactly 3 numbers, got 4"],
        absent: &RUST_WORDS,
    },
    Row {
        what: "a fraction for a count",
        scene: Scene::Text("[fixup]\niterations = 2.5\n"),
        args: &["run", "scene.toml"],
        expect: &["`fixup.iterations`", "a whole number ≥ 0"],
        absent: &["u32"],
    },
    Row {
        what: "infinite mass",
        scene: Scene::Text("[cloth]\nmass = inf\n"),
        args: &["run", "scene.toml"],
        expect: &["`cloth.mass`", "must be finite", "got inf"],
        absent: &[],
    },
    Row {
        what: "NaN mass",
        scene: Scene::Text("[cloth]\nmass = nan\n"),
        args: &["run", "scene.toml"],
        expect: &["`cloth.mass`", "must be finite", "got NaN"],
        absent: &[],
    },
    Row {
        what: "a huge stiffness is printed with an exponent",
        scene: Scene::Text("[springs.stretch]\nstiffness = 1e300\n"),
        args: &["run", "scene.toml"],
        expect: &["`springs.stretch.stiffness`", "≤ 1e9", "got 1e300"],
        absent: &[DIGIT_RUN],
    },
    Row {
        what: "a directory as the scene",
        scene: Scene::Directory,
        args: &["run", "scene.toml"],
        expect: &["scene.toml", "is a directory, not a scene file"],
        absent: &[],
    },
    Row {
        what: "a symlink to /dev/zero as the scene",
        scene: Scene::DevZero,
        args: &["run", "scene.toml"],
        expect: &["scene.toml", "not a regular file"],
        absent: &[],
    },
    Row {
        what: "a FIFO as the scene",
        scene: Scene::Fifo,
        args: &["run", "scene.toml"],
        expect: &["scene.toml", "not a regular file"],
        absent: &[],
    },
    Row {
        what: "a scene file over the size cap",
        scene: Scene::Oversized,
        args: &["run", "scene.toml"],
        expect: &["scene.toml", "larger than 1 MiB"],
        absent: &[],
    },
    Row {
        what: "a NUL byte in a scene file",
        scene: Scene::Text("[simulation]\ndt = 0.01\0\n"),
        args: &["run", "scene.toml"],
        expect: &[
            "scene.toml",
            "line 2, column 10",
            "a NUL byte (U+0000)",
            "no control character but tab, newline and carriage return",
        ],
        absent: &["invalid float"],
    },
    Row {
        what: "a density whose masses are infinite in f32",
        scene: Scene::Text("[cloth]\nresolution = [5, 5]\n[material]\ndensity = 1e300\n"),
        args: &["run", "scene.toml"],
        expect: &["`material.density`", "normal f32 numbers", "got 1e300"],
        absent: &[],
    },
    Row {
        what: "bench overhang: a negative --density",
        scene: Scene::None,
        args: &["bench", "overhang", "--density", "-1"],
        expect: &["`--density`", "> 0 (kg/m²)", "got -1"],
        absent: &["unexpected argument"],
    },
    Row {
        what: "bench overhang: --bending 0",
        scene: Scene::None,
        args: &["bench", "overhang", "--bending", "0"],
        expect: &["`--bending`", "0 < bending ≤ 1", "got 0"],
        absent: &["material.stretch"],
    },
    Row {
        what: "bench overhang: a density whose strips no cloth can hold",
        scene: Scene::None,
        args: &["bench", "overhang", "--density", "1e-300"],
        expect: &["`--density`", "with bending 5e-6 N·m", "Γ from 1 to 100"],
        absent: &["`cloth.origin"],
    },
    Row {
        what: "bench overhang: --segments beyond its range",
        scene: Scene::None,
        args: &["bench", "overhang", "--segments", "100000000"],
        expect: &["--segments", "2 ≤ N ≤ 256"],
        absent: &["cloth.resolution"],
    },
    Row {
        what: "bench overhang: a negative --segments",
        scene: Scene::None,
        args: &["bench", "overhang", "--segments", "-3"],
        expect: &["--segments", "2 ≤ N ≤ 256"],
        absent: &["unexpected argument"],
    },
    Row {
        what: "bench drape: a size that is not a number",
        scene: Scene::None,
        args: &["bench", "drape", "--sizes", "5,x"],
        expect: &["--sizes", "'x'", "each 3 ≤ N ≤ 257"],
        absent: &["ParseIntError", "invalid digit"],
    },
    Row {
        what: "bench drape: a negative size",
        scene: Scene::None,
        args: &["bench", "drape", "--sizes", "-5"],
        expect: &["--sizes", "each 3 ≤ N ≤ 257"],
        absent: &["unexpected argument"],
    },
    Row {
        what: "bench drape: one file for the CSV and the chart",
        scene: Scene::None,
        args: &["bench", "drape", "--csv", "same.txt", "--chart", "same.txt"],
        expect: &["--csv and --chart are the same file (same.txt)"],
        absent: &[],
    },
    Row {
        what: "bench cantilever: one file for the CSV and the chart",
        scene: Scene::None,
        args: &[
            "bench",
            "cantilever",
            "--quick",
            "--csv",
            "t.csv",
            "--chart",
            "./t.csv",
        ],
        expect: &["--csv and --chart are the same file (t.csv)"],
        absent: &[],
    },
    Row {
        what: "render refused by the solver after the device opened",
        scene: Scene::Text(
            "[simulation]\nintegrator = \"explicit\"\ndt = 0.001\n[cloth]\n\
             resolution = [11, 11]\nsize = [1.0, 1.0]\n[material]\nbending = 0.7\n",
        ),
        args: &[
            "render",
            "scene.toml",
            "--out",
            "frames/sub",
            "--frames",
            "1",
            "--size",
            "64x48",
        ],
        expect: &["`material.bending`", "at most"],
        absent: &[],
    },
];

/// Puts the row's `scene.toml` in `dir`.
fn make_scene(dir: &Path, scene: &Scene) {
    let path = dir.join("scene.toml");
    match scene {
        Scene::None => {}
        Scene::Text(text) => std::fs::write(&path, text).expect("write the scene"),
        Scene::Directory => std::fs::create_dir(&path).expect("create the directory"),
        Scene::DevZero => {
            std::os::unix::fs::symlink("/dev/zero", &path).expect("symlink to /dev/zero");
        }
        Scene::Fifo => {
            let made = Command::new("mkfifo")
                .arg(&path)
                .status()
                .expect("run mkfifo");
            assert!(made.success(), "mkfifo {}", path.display());
        }
        Scene::Oversized => {
            let mut text = String::from("[simulation]\ndt = 0.01\n");
            let size = usize::try_from(MAX_SCENE_BYTES).expect("small") + 1;
            text.push('#');
            text.push_str(&"-".repeat(size - text.len()));
            std::fs::write(&path, text).expect("write the scene");
        }
    }
}

/// Runs `wgcloth args…` in `dir`, outputs of `run` named into it too.
fn wgcloth_in(dir: &Path, args: &[&str]) -> Output {
    let mut command = Command::new(BIN);
    command.current_dir(dir).args(args);
    if args.first() == Some(&"run") {
        command.args(RUN_OUT);
    }
    command.output().expect("run the wgcloth binary")
}

#[test]
fn bad_command_lines_and_scene_files_are_refused_clearly_and_write_nothing() {
    let mut failures = Vec::new();
    for (k, row) in ROWS.iter().enumerate() {
        let dir = TempDir::new(&format!("messages-{k}"));
        make_scene(&dir.0, &row.scene);
        let before = dir.files();
        let out = wgcloth_in(&dir.0, row.args);
        let wrong = refusal_faults(&out, row.expect, row.absent, &before, &dir.files());
        if !wrong.is_empty() {
            failures.push(format!(
                "{}: {}\n    stderr: {}",
                row.what,
                wrong.join("; "),
                stderr(&out)
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        ROWS.len(),
        failures.join("\n")
    );
}

#[test]
fn a_valid_run_writes_its_outputs_where_the_rows_look() {
    // The rows' "nothing written" check could fail: the same command line
    // with valid values writes both outputs into the row's directory.
    let dir = TempDir::new("messages-valid-run");
    let out = wgcloth_in(
        &dir.0,
        &["run", "hanging", "--steps", "0", "--trace-every", "1"],
    );
    assert_status(&out, 0);
    assert_eq!(dir.files(), ["positions.txt", "trace.csv"]);
}

#[test]
fn a_self_collision_thickness_at_its_documented_maximum_is_accepted() {
    // A 0.3 m cloth of 4 × 4 particles: rest spacing 0.1 m, so at most
    // 4 × 0.1 = 0.4 m, which its computed spacing (0.09999999999999998)
    // once put just out of reach.
    let dir = TempDir::new("messages-thickness-maximum");
    let scene = "[cloth]\nresolution = [4, 4]\nsize = [0.3, 0.3]\n[self_collision]\n";
    std::fs::write(dir.join("scene.toml"), format!("{scene}thickness = 0.4\n"))
        .expect("write the scene");
    let out = wgcloth_in(&dir.0, &["run", "scene.toml", "--steps", "1"]);
    assert_status(&out, 0);
    std::fs::write(dir.join("scene.toml"), format!("{scene}thickness = 0.41\n"))
        .expect("write the scene");
    let out = wgcloth_in(&dir.0, &["run", "scene.toml", "--steps", "1"]);
    assert_status(&out, EXIT_INVALID);
    assert!(
        stderr(&out).contains("to 1e-9 relative"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_folder_named_like_a_builtin_scene_does_not_hide_it() {
    let dir = TempDir::new("messages-builtin-folder");
    std::fs::create_dir(dir.join("flag")).expect("create the folder");
    let out = wgcloth_in(&dir.0, &["run", "flag", "--steps", "0"]);
    assert_status(&out, 0);
    assert!(stdout(&out).contains("flag"), "{}", stdout(&out));
    // Any other folder is refused as one.
    let out = wgcloth_in(&dir.0, &["run", "./flag", "--steps", "0"]);
    assert_status(&out, EXIT_INVALID);
    assert!(stderr(&out).contains("is a directory"), "{}", stderr(&out));
}
