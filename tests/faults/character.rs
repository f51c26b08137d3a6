//! Fault rows: a scene's `[character]` under `wgcloth run`, which once
//! ignored it without a word (a walking and a standing character gave the
//! same positions) while `render` played it. `run` now poses the
//! character as `render` does, every backend and `--batch` included.

use std::fs;
use std::path::Path;

use crate::cli_common::{assert_status, wgcloth, TempDir, LAVAPIPE};

/// The built-in `cape` scene's keys (stands 0.6 s, then jogs along +z at
/// 2 m/s) replaced by one key at the origin: the character stands; its
/// render mesh read from `scenes/`.
fn standing_cape() -> String {
    let cape = fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cape.toml"))
        .expect("the cape scene");
    // The render mesh from the scenes folder, where the scene is written
    // elsewhere.
    let cape = cape.replace(
        "render_mesh = \"cape_detail.obj\"",
        concat!(
            "render_mesh = \"",
            env!("CARGO_MANIFEST_DIR"),
            "/scenes/cape_detail.obj\""
        ),
    );
    let keys = cape.find("[[character.key]]").expect("the cape's keys");
    let camera = cape.find("[camera]").expect("the cape's camera");
    format!(
        "{}[[character.key]]\ntime = 0.0\nposition = [0.0, 0.0, 0.0]\nyaw = 0.0\n\n{}",
        &cape[..keys],
        &cape[camera..]
    )
}

/// Simulated time of each run \[s\]: a tenth of a second past the cape's
/// standing key (each GPU run's 168 implicit steps on lavapipe are most of
/// the test's time).
const SECONDS: &str = "0.7";

/// How far the cape's character has jogged along +z at [`SECONDS`] \[m\]:
/// 2.4 m between its keys at 0.6 s and 1.8 s, so 0.2 m by 0.7 s, 200 000
/// times [`PIN_TOLERANCE`].
const JOGGED: f64 = 0.2;

/// The cape's particle 0, its top-left pin, rests at this z \[m\].
const PIN_REST_Z: f64 = -0.2;

/// How close a pin lands to its target \[m\]: it moves to the target over
/// the frame and lands on it, its position rounded to `f32` (an ulp of
/// 0.6 m is 6e-8 m).
const PIN_TOLERANCE: f64 = 1e-6;

/// How far the GPU's final positions may be from the `f32` CPU solver's
/// \[m\]: the same arithmetic, summed in the same order; the implicit
/// solve's CG stops at a relative residual of 1e-4, so a last-bit
/// difference in one dot product may change an iterate by far less.
const GPU_CPU_TOLERANCE: f64 = 1e-5;

/// `wgcloth run SCENE --seconds 1 --positions-out FILE EXTRA…`: the
/// positions it wrote.
fn positions(dir: &TempDir, scene: &Path, name: &str, extra: &[&str]) -> Vec<[f64; 3]> {
    let file = dir.join(name);
    let mut args = vec![
        "run",
        scene.to_str().expect("a UTF-8 path"),
        "--seconds",
        SECONDS,
        "--positions-out",
        file.to_str().expect("a UTF-8 path"),
    ];
    args.extend(extra);
    let out = wgcloth(&args);
    assert_status(&out, 0);
    fs::read_to_string(&file)
        .expect("the positions")
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split(' ').map(|x| x.parse().expect("a number")).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

/// The largest coordinate difference between two runs \[m\].
fn largest_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |i| (p[i] - q[i]).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn run_plays_a_character_on_every_backend_and_in_a_batch() {
    let dir = TempDir::new("character-run");
    let walking = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cape.toml"));
    let standing = dir.write("standing.toml", &standing_cape());
    let backends: [(&str, &[&str]); 4] = [
        ("cpu-f64", &["--backend", "cpu"]),
        ("cpu-f32", &["--backend", "cpu", "--precision", "f32"]),
        ("gpu", &["--backend", "gpu", "--adapter", LAVAPIPE]),
        (
            "gpu-batch",
            &["--backend", "gpu", "--adapter", LAVAPIPE, "--batch", "2"],
        ),
    ];
    let z = |x: &[[f64; 3]]| x[0][2];
    // The control, on one backend: the same scene with a character that
    // stands keeps its pins where they rest.
    let stand = positions(&dir, &standing, "stand.txt", backends[0].1);
    assert!(
        (z(&stand) - PIN_REST_Z).abs() < PIN_TOLERANCE,
        "the standing character's pin at z = {}",
        z(&stand)
    );
    let mut walked = Vec::new();
    for (name, extra) in backends {
        // The pins ride on the character as it jogs, on every backend.
        let walk = positions(&dir, walking, &format!("{name}-walk.txt"), extra);
        assert!(
            (z(&walk) - (PIN_REST_Z + JOGGED)).abs() < PIN_TOLERANCE,
            "{name}: the walking character's pin at z = {}",
            z(&walk)
        );
        walked.push((name, walk));
    }
    let (_, cpu_f32) = &walked[1];
    let (_, gpu) = &walked[2];
    let (_, batch) = &walked[3];
    let d = largest_difference(gpu, cpu_f32);
    assert!(d < GPU_CPU_TOLERANCE, "GPU against CPU f32: {d} m");
    assert_eq!(gpu, batch, "copy 0 of a batch against a lone cloth");
}
