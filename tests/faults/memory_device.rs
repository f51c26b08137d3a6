//! Fault rows: memory and the device. Scenes too big for the host's memory
//! (under `ulimit -v`) or the device, images too big to render, a bogus
//! `WGPU_BACKEND`, a device destroyed under a host's feet. Every row
//! asserts the exit status (never a panic's 101, an abort's 134 or a
//! crash's 139), the message, and that no output reached the disk.

use std::process::{Command, Output};

use wgcloth::gpu::{GpuContext, GpuSolver};
use wgcloth::{Error, Scene};

use crate::cli_common::{
    assert_status, stderr, wgcloth, TempDir, BIN, EXIT_INVALID, EXIT_NO_ADAPTER, LAVAPIPE,
};
use crate::{cube_collider_scene, CUBE_OBJ, FINE_BAKE};

/// A cloth of 10⁶ particles (two pinned corners), explicit: its model
/// alone is about 0.4 GiB, the f64 CPU solver's workspace 1.1 GiB more.
const MILLION: &str = r#"
[simulation]
integrator = "explicit"
dt = 0.001
[cloth]
resolution = [1000, 1000]
"#;

/// 10⁶ particles with the dense semi-implicit filter: 10¹² entries, 8 TB
/// in f64.
const DENSE_MILLION: &str = r#"
[simulation]
integrator = "semi-implicit"
dt = 0.001
[cloth]
resolution = [2, 500000]
[semi_implicit]
filter = "dense"
"#;

/// 440 × 440 particles, explicit: within lavapipe's buffer limits (its
/// largest buffer, about 108 MB, under the 128 MiB storage binding), and
/// its own buffers (0.46 GiB) within what [`GPU_ADDRESS_SPACE_KIB`] leaves
/// after lavapipe's own mappings (0.88 GiB), but not with the kernel
/// compiler's reserve (0.5 GiB) on top.
const FOUR_FORTY: &str = r#"
[simulation]
integrator = "explicit"
dt = 0.001
[cloth]
resolution = [440, 440]
"#;

/// `ulimit -v` for the CPU rows \[KiB\]: about 1 GB, which the built-in
/// `hanging` scene runs under (the control row checks it) and the 10⁶
/// particle cloth's solver (1.1 GiB) does not fit.
const CPU_ADDRESS_SPACE_KIB: u64 = 1_000_000;

/// `ulimit -v` for the GPU rows \[KiB\]: about 1.4 GB. Lavapipe maps about
/// 0.5 GB of address space once a device is open (with
/// [`MALLOC_ARENAS`] and [`LAVAPIPE_THREADS`]); `hanging` runs in what is
/// left (the control row), a 440 × 440 cloth or an 8192 × 8192 image,
/// with the kernel compiler's reserve, does not.
const GPU_ADDRESS_SPACE_KIB: u64 = 1_400_000;

/// `MALLOC_ARENA_MAX` of the limited runs: glibc reserves 64 MiB of
/// address space per malloc arena, up to eight per core, so without a cap
/// what `ulimit -v` leaves would depend on the machine's core count.
const MALLOC_ARENAS: &str = "2";

/// `LP_NUM_THREADS` of the limited runs: lavapipe's worker threads (one
/// per core by default), each with its stack, fixed for the same reason.
const LAVAPIPE_THREADS: &str = "2";

/// `ulimit -v` for the collider rows \[KiB\]: about 51 MB. Before a
/// scene's colliders bake (no device open) the binary maps about 16 MB,
/// so a 5 × 5 cloth over a coarse cube runs under it (the control) and
/// the 245³-point grid of [`FINE_BAKE`] (56 MiB of samples) cannot fit.
const BAKE_ADDRESS_SPACE_KIB: u64 = 50_000;

/// Runs the binary with `args` under `ulimit -v kib`, in `dir`, with the
/// address space it maps made independent of the machine's core count.
fn wgcloth_limited(kib: u64, dir: &TempDir, args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {kib} && exec \"$0\" \"$@\""))
        .arg(BIN)
        .args(args)
        .env("MALLOC_ARENA_MAX", MALLOC_ARENAS)
        .env("LP_NUM_THREADS", LAVAPIPE_THREADS)
        .current_dir(&dir.0)
        .output()
        .expect("run the wgcloth binary under sh")
}

/// Where [`run_limited`] runs a scene.
#[derive(Clone, Copy)]
enum Backend {
    /// The CPU, under [`CPU_ADDRESS_SPACE_KIB`].
    Cpu,
    /// Lavapipe, under [`GPU_ADDRESS_SPACE_KIB`].
    Lavapipe,
}

/// Runs `wgcloth run SCENE --steps 1 --positions-out p.txt` in `dir` on
/// `backend`, under its address-space limit.
fn run_limited(dir: &TempDir, scene: &str, backend: Backend) -> Output {
    let mut args = vec!["run", scene, "--steps", "1", "--positions-out", "p.txt"];
    let kib = match backend {
        Backend::Cpu => CPU_ADDRESS_SPACE_KIB,
        Backend::Lavapipe => {
            args.extend(["--backend", "gpu", "--adapter", LAVAPIPE]);
            GPU_ADDRESS_SPACE_KIB
        }
    };
    wgcloth_limited(kib, dir, &args)
}

/// The exact byte count a memory error gives in parentheses after the
/// amount it needs: `needs 7.3 TiB (8000999498664 bytes)`.
fn bytes_needed(message: &str) -> u64 {
    let after = message
        .split_once(" needs ")
        .unwrap_or_else(|| panic!("no amount in: {message}"))
        .1;
    let inside = after
        .split_once('(')
        .and_then(|(_, rest)| rest.split_once(" bytes)"))
        .unwrap_or_else(|| panic!("no exact byte count in: {message}"))
        .0;
    inside
        .parse()
        .unwrap_or_else(|e| panic!("`{inside}` is not a byte count ({e}): {message}"))
}

/// The message of a refusal that the memory could not hold a scene: one
/// `error:` line, no panic or backtrace.
#[track_caller]
fn assert_refused(out: &Output, needles: &[&str]) -> String {
    assert_status(out, EXIT_INVALID);
    let err = stderr(out);
    assert!(err.starts_with("error: "), "{err}");
    assert_eq!(err.lines().count(), 1, "one line expected: {err}");
    for needle in needles {
        assert!(err.contains(needle), "`{needle}` missing from: {err}");
    }
    err
}

#[test]
fn a_dense_filter_of_a_million_particles_is_refused_with_the_amount() {
    let dir = TempDir::new("memdev-dense");
    let scene = dir.write("dense.toml", DENSE_MILLION);
    let positions = dir.join("positions.txt");
    let out = wgcloth(&[
        "run".as_ref(),
        scene.as_os_str(),
        "--steps".as_ref(),
        "1".as_ref(),
        "--positions-out".as_ref(),
        positions.as_os_str(),
    ]);
    let err = assert_refused(
        &out,
        &[
            "dense semi-implicit filter",
            "filter = \"banded\"",
            "available",
        ],
    );
    let free = 1_000_000u64 - 2;
    assert!(
        bytes_needed(&err) >= free * free * 8,
        "the amount does not count the f64 inverse's {free}² entries: {err}"
    );
    assert_eq!(dir.files(), ["dense.toml"], "nothing else on disk");
}

#[test]
fn control_a_small_scene_runs_under_the_cpu_rows_limit() {
    let dir = TempDir::new("memdev-cpu-control");
    let out = run_limited(&dir, "hanging", Backend::Cpu);
    assert_status(&out, 0);
    assert_eq!(dir.files(), ["p.txt"]);
}

#[test]
fn a_million_particles_under_an_address_space_limit_are_refused_on_the_cpu() {
    let dir = TempDir::new("memdev-cpu-million");
    dir.write("million.toml", MILLION);
    let out = run_limited(&dir, "million.toml", Backend::Cpu);
    let err = assert_refused(&out, &["1000000 particles", "ulimit -v"]);
    assert!(
        bytes_needed(&err) > CPU_ADDRESS_SPACE_KIB * 1024 / 4,
        "an implausibly small amount: {err}"
    );
    assert_eq!(dir.files(), ["million.toml"], "nothing else on disk");
}

#[test]
fn a_collider_grid_beyond_the_memory_is_refused_naming_the_collider() {
    let dir = TempDir::new("memdev-bake");
    dir.write("cube.obj", CUBE_OBJ);
    dir.write("coarse.toml", &cube_collider_scene(16));
    dir.write("fine.toml", &cube_collider_scene(FINE_BAKE));
    let args = |scene| ["run", scene, "--steps", "1", "--positions-out", "p.txt"];
    let out = wgcloth_limited(BAKE_ADDRESS_SPACE_KIB, &dir, &args("coarse.toml"));
    assert_status(&out, 0);
    std::fs::remove_file(dir.join("p.txt")).expect("the control wrote p.txt");
    let out = wgcloth_limited(BAKE_ADDRESS_SPACE_KIB, &dir, &args("fine.toml"));
    let side = FINE_BAKE + 5;
    let err = assert_refused(
        &out,
        &[
            "the distance grid of `collider[0]`",
            &format!("{side} × {side} × {side} lattice points"),
            "ulimit -v",
        ],
    );
    assert!(
        bytes_needed(&err) >= 4 * u64::from(side).pow(3),
        "the amount does not count the grid's f32 samples: {err}"
    );
    assert_eq!(dir.files(), ["coarse.toml", "cube.obj", "fine.toml"]);
}

#[test]
fn control_a_small_scene_runs_on_lavapipe_under_the_gpu_rows_limit() {
    let dir = TempDir::new("memdev-gpu-control");
    let out = run_limited(&dir, "hanging", Backend::Lavapipe);
    assert_status(&out, 0);
    assert_eq!(dir.files(), ["p.txt"]);
}

#[test]
fn a_million_particles_on_lavapipe_under_an_address_space_limit_are_refused() {
    let dir = TempDir::new("memdev-gpu-million");
    dir.write("million.toml", MILLION);
    let out = run_limited(&dir, "million.toml", Backend::Lavapipe);
    // Lavapipe's 128 MiB storage-binding limit refuses it before its
    // memory is counted; a device with larger limits would be refused by
    // the memory check. Either way the message says what needs what.
    assert_refused(&out, &["needs"]);
    assert_eq!(dir.files(), ["million.toml"], "nothing else on disk");
}

#[test]
fn a_cloth_beyond_lavapipes_memory_under_a_limit_is_refused_naming_the_gpu_solver() {
    let dir = TempDir::new("memdev-gpu-four-forty");
    dir.write("four-forty.toml", FOUR_FORTY);
    let out = run_limited(&dir, "four-forty.toml", Backend::Lavapipe);
    // The driver's kernel-compiler reserve is said to be the driver's, not
    // counted as the cloth's own need.
    assert_refused(
        &out,
        &[
            "GPU solver for 193600 particles (",
            " of its own, plus the driver's reserve of 512.0 MiB",
            "ulimit -v",
        ],
    );
    assert_eq!(dir.files(), ["four-forty.toml"], "nothing else on disk");
}

#[test]
fn an_image_beyond_the_texture_limit_is_refused_naming_size() {
    let dir = TempDir::new("memdev-render-huge");
    let frames = dir.join("frames");
    let out = wgcloth(&[
        "render".as_ref(),
        "hanging".as_ref(),
        "--size".as_ref(),
        "100000x100000".as_ref(),
        "--frames".as_ref(),
        "1".as_ref(),
        "--adapter".as_ref(),
        LAVAPIPE.as_ref(),
        "--out".as_ref(),
        frames.as_os_str(),
    ]);
    assert_refused(
        &out,
        &[
            "--size 100000x100000",
            "max_texture_dimension_2d",
            "the image's width",
        ],
    );
    assert!(!stderr(&out).contains("cloth"), "{}", stderr(&out));
    assert!(dir.files().is_empty(), "the output folder was created");
}

#[test]
fn an_image_beyond_memory_under_a_limit_is_refused_naming_size() {
    let dir = TempDir::new("memdev-render-8192");
    let out = wgcloth_limited(
        GPU_ADDRESS_SPACE_KIB,
        &dir,
        &[
            "render",
            "hanging",
            "--size",
            "8192x8192",
            "--frames",
            "1",
            "--out",
            "frames",
            "--adapter",
            LAVAPIPE,
        ],
    );
    let err = assert_refused(&out, &["--size 8192x8192", "8192×8192 image", "ulimit -v"]);
    // Its colour and depth textures alone, 4 bytes a pixel each.
    assert!(bytes_needed(&err) >= 8192 * 8192 * 8, "{err}");
    assert!(dir.files().is_empty(), "the output folder was created");
}

#[test]
fn a_bogus_wgpu_backend_is_refused_naming_the_variable_and_the_names() {
    let dir = TempDir::new("memdev-backend");
    let out = Command::new(BIN)
        .args(["run", "hanging", "--steps", "1", "--backend", "gpu"])
        .args(["--positions-out", "p.txt"])
        .env("WGPU_BACKEND", "vulkan,bogus")
        .current_dir(&dir.0)
        .output()
        .expect("run the wgcloth binary");
    assert_refused(
        &out,
        &["WGPU_BACKEND", "`bogus` is not a backend", "vulkan, metal"],
    );
    assert!(dir.files().is_empty(), "nothing on disk");
}

#[test]
fn mesas_runtime_dir_noise_is_not_shown() {
    for value in [None, Some("relative/dir"), Some("/nonexistent/wgcloth")] {
        let mut cmd = Command::new(BIN);
        cmd.args(["run", "hanging", "--steps", "1", "--backend", "gpu"])
            .args(["--adapter", LAVAPIPE]);
        match value {
            Some(v) => cmd.env("XDG_RUNTIME_DIR", v),
            None => cmd.env_remove("XDG_RUNTIME_DIR"),
        };
        let out = cmd.output().expect("run the wgcloth binary");
        assert_status(&out, 0);
        assert!(
            !stderr(&out).contains("XDG_RUNTIME_DIR"),
            "XDG_RUNTIME_DIR={value:?}: {}",
            stderr(&out)
        );
    }
}

/// A host whose device is destroyed between steps (as a driver reset
/// would lose it) gets errors from stepping and reading back, not a
/// panic, and its context reports the loss.
#[test]
fn a_destroyed_device_gives_errors_not_panics() {
    let ctx = GpuContext::new(Some(LAVAPIPE)).expect("lavapipe (Mesa's software Vulkan)");
    let scene = Scene::builtin("hanging").expect("the built-in scene");
    let model = scene.model().expect("its model");
    let mut solver =
        GpuSolver::new(&ctx.device, &ctx.queue, &model, &scene.params).expect("a solver");
    solver.step(2).expect("steps on a live device");
    assert!(ctx.check().is_ok(), "no fault before the loss");

    ctx.device.destroy();
    match solver.step(2) {
        // What failed is named, on one line (the CLI's `error:` line).
        Err(Error::Gpu(message)) => {
            assert!(message.contains("read-back"), "{message}");
            assert_eq!(message.lines().count(), 1, "{message}");
        }
        other => panic!("stepping a destroyed device: expected a GPU error, got {other:?}"),
    }
    match solver.read_state() {
        Err(Error::Gpu(message)) => assert!(message.contains("read-back"), "{message}"),
        other => panic!("reading back from a destroyed device: got {other:?}"),
    }
    let lost = ctx.check().expect_err("the context reports the loss");
    assert!(lost.to_string().contains("lost"), "{lost}");
}

/// `ulimit -v` under which lavapipe is found but its device cannot be
/// opened \[KiB\]: about 0.38 GB, the middle of the band where that
/// happened on the development machine (with [`MALLOC_ARENAS`] and
/// [`LAVAPIPE_THREADS`]): under 0.3 GB the Vulkan loader cannot load the
/// driver at all (no adapter), over 0.42 GB the device opens and the GPU
/// solver's memory check refuses the cloth (status 2).
const DEVICE_ADDRESS_SPACE_KIB: u64 = 375_000;

/// A device that cannot be opened for want of memory is said to be out of
/// memory (no advice to install a driver that is installed), with the
/// status of a device that could not be opened (4), never a panic.
#[test]
fn a_device_out_of_memory_is_said_so_without_a_panic() {
    let dir = TempDir::new("memdev-open");
    let out = wgcloth_limited(
        DEVICE_ADDRESS_SPACE_KIB,
        &dir,
        &[
            "run",
            "hanging",
            "--steps",
            "1",
            "--backend",
            "gpu",
            "--positions-out",
            "p.txt",
        ],
    );
    let err = stderr(&out);
    assert_status(&out, EXIT_NO_ADAPTER);
    assert!(
        err.contains("was found but could not be opened: out of memory"),
        "{err}"
    );
    assert!(err.contains("ulimit -v"), "{err}");
    assert!(
        !err.contains("apt-get"),
        "advice for a missing driver: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(dir.files(), Vec::<String>::new(), "nothing on disk");
}
