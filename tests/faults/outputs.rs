//! Fault rows: output files. Planted links, devices and FIFOs as outputs,
//! a second output that fails, a file size limit standing in for a full
//! disk, interrupted runs and renders, stale temporaries. Each row asserts
//! the exit status, the message and what is on disk afterwards.
//!
//! A full disk is simulated with `RLIMIT_FSIZE` (`ulimit -f` in bash, in
//! 1024-byte blocks, with SIGXFSZ ignored so that a write past the limit
//! fails with EFBIG, "File too large", instead of killing the process):
//! mounting a small tmpfs needs privileges a test cannot count on.

use std::fs;
use std::os::unix::fs::{FileTypeExt as _, PermissionsExt as _};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::cli_common::*;

/// Exit status of a command stopped by Ctrl-C or SIGTERM.
const EXIT_INTERRUPTED: i32 = 130;
/// Exit status of an output that could not be written.
const EXIT_FAILURE: i32 = 1;

/// An explicit `side × side` cloth held by two corners, 5 steps.
fn cloth_scene(side: u32) -> String {
    format!(
        "[simulation]\nintegrator = \"explicit\"\ndt = 0.002\nduration = 0.01\n\n\
         [cloth]\nresolution = [{side}, {side}]\npins = [\"top-left\", \"top-right\"]\n"
    )
}

/// The side of the cloth most rows use: a run takes milliseconds.
const SMALL_SIDE: u32 = 5;
const SMALL_PARTICLES: usize = 25;

/// The side of the cloth of the failing-second-output row: its positions
/// file is tens of kilobytes and its trace (two states, each line twice as
/// long) about three times that, so a file size limit between the two
/// lets the positions through and stops the trace's last state.
const MEDIUM_SIDE: u32 = 20;

/// What a planted link points at and must keep.
const VICTIM: &str = "the user's precious file\n";

/// How long a spawned command may take to reach the point where a test
/// interrupts it: lavapipe compiles the render pipelines first, which
/// takes seconds, more on a loaded machine.
const START_TIMEOUT: Duration = Duration::from_secs(300);

fn path_str(path: &Path) -> &str {
    path.to_str().expect("a UTF-8 temp path")
}

/// Runs `script` with bash (`$BIN` is the binary), with SIGXFSZ ignored.
fn bash(dir: &TempDir, script: &str) -> Output {
    Command::new("bash")
        .arg("-c")
        .arg(format!("trap '' XFSZ; {script}"))
        .env("BIN", BIN)
        .current_dir(&dir.0)
        .output()
        .expect("run bash")
}

/// The hidden files (temporaries, backups) in `dir`, sorted.
fn hidden(dir: &Path) -> Vec<String> {
    names_in(dir)
        .into_iter()
        .filter(|n| n.starts_with('.'))
        .collect()
}

/// Decodes every `frame_*.png` in `dir` (each must be a whole PNG of
/// `width × height`); returns their names, sorted.
fn decoded_frames(dir: &Path, width: u32, height: u32) -> Vec<String> {
    let frames: Vec<String> = names_in(dir)
        .into_iter()
        .filter(|n| n.starts_with("frame_") && n.ends_with(".png"))
        .collect();
    for name in &frames {
        let file = fs::File::open(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .unwrap_or_else(|e| panic!("{name} does not decode: {e}"));
        let mut rgba = vec![0; reader.output_buffer_size().expect("a PNG size")];
        let info = reader
            .next_frame(&mut rgba)
            .unwrap_or_else(|e| panic!("{name}'s pixels do not decode: {e}"));
        assert_eq!((info.width, info.height), (width, height), "{name}");
    }
    frames
}

#[track_caller]
fn assert_mentions(out: &Output, words: &[&str]) {
    let err = stderr(out);
    for w in words {
        assert!(err.contains(w), "stderr lacks `{w}`:\n{err}");
    }
}

#[test]
fn a_symlink_as_the_output_is_refused_and_its_target_kept() {
    let dir = TempDir::new("out-link");
    let scene = dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let victim = dir.write("victim.txt", VICTIM);
    let link = dir.join("pos.txt");
    std::os::unix::fs::symlink(&victim, &link).expect("plant a link");
    let out = wgcloth(&["run", path_str(&scene), "--positions-out", path_str(&link)]);
    assert_status(&out, EXIT_INVALID);
    assert_mentions(&out, &["pos.txt: is a symbolic link, not a regular file"]);
    assert_eq!(fs::read_to_string(&victim).expect("the victim"), VICTIM);
    let meta = fs::symlink_metadata(&link).expect("the link");
    assert!(meta.file_type().is_symlink(), "the link was replaced");
    assert_eq!(dir.files(), ["pos.txt", "small.toml", "victim.txt"]);
}

/// A link planted where the temporary of the process's PID used to go
/// (`.NAME.PID.tmp`; `exec` keeps the shell's PID, so `$$` is the run's):
/// the run neither writes through it nor trips over it.
#[test]
fn a_symlink_at_a_temporary_name_is_not_written_through() {
    let dir = TempDir::new("tmp-link");
    dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    dir.write("victim.txt", VICTIM);
    let out = bash(
        &dir,
        "ln -s victim.txt .pos.txt.$$.tmp && \
         exec \"$BIN\" run small.toml --positions-out pos.txt",
    );
    assert_status(&out, 0);
    assert_eq!(
        fs::read_to_string(dir.join("victim.txt")).expect("victim"),
        VICTIM
    );
    let positions = fs::read_to_string(dir.join("pos.txt")).expect("the positions");
    assert_eq!(positions.lines().count(), SMALL_PARTICLES);
    let planted = hidden(&dir.0);
    assert_eq!(planted.len(), 1, "temporaries left: {planted:?}");
    let meta = fs::symlink_metadata(dir.join(&planted[0])).expect("the planted link");
    assert!(
        meta.file_type().is_symlink(),
        "the planted link was replaced"
    );
}

#[test]
fn a_symlink_at_a_frame_temporary_name_is_not_written_through() {
    let dir = TempDir::new("frame-link");
    dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    dir.write("victim.txt", VICTIM);
    fs::create_dir(dir.join("frames")).expect("create the frame folder");
    let out = bash(
        &dir,
        "ln -s ../victim.txt frames/.frame_00000.png.$$.tmp && \
         exec \"$BIN\" render small.toml --out frames --frames 2 --size 64x48 \
         --adapter llvmpipe",
    );
    assert_status(&out, 0);
    assert_eq!(
        fs::read_to_string(dir.join("victim.txt")).expect("victim"),
        VICTIM
    );
    let frames = dir.join("frames");
    assert_eq!(
        decoded_frames(&frames, 64, 48),
        ["frame_00000.png", "frame_00001.png"]
    );
    assert_eq!(
        hidden(&frames).len(),
        1,
        "temporaries: {:?}",
        hidden(&frames)
    );
}

/// A regular file left at the old temporary name by a killed run, as a
/// reused PID would find it: the run goes on and leaves it alone.
#[test]
fn a_stale_temporary_does_not_block_a_later_run() {
    let dir = TempDir::new("stale");
    dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let out = bash(
        &dir,
        "echo stale > .pos.txt.$$.tmp && \
         exec \"$BIN\" run small.toml --positions-out pos.txt",
    );
    assert_status(&out, 0);
    let positions = fs::read_to_string(dir.join("pos.txt")).expect("the positions");
    assert_eq!(positions.lines().count(), SMALL_PARTICLES);
    let stale = hidden(&dir.0);
    assert_eq!(stale.len(), 1, "{stale:?}");
    assert_eq!(
        fs::read_to_string(dir.join(&stale[0])).expect("stale"),
        "stale\n"
    );
}

#[test]
fn dev_null_as_an_output_is_refused_and_stays_a_device() {
    let dir = TempDir::new("dev-null");
    let scene = dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let out = wgcloth(&["run", path_str(&scene), "--positions-out", "/dev/null"]);
    assert_status(&out, EXIT_INVALID);
    assert_mentions(
        &out,
        &["/dev/null: is a character device, not a regular file"],
    );
    let meta = fs::symlink_metadata("/dev/null").expect("/dev/null");
    assert!(meta.file_type().is_char_device(), "/dev/null was replaced");
    let left: Vec<String> = hidden(Path::new("/dev"))
        .into_iter()
        .filter(|n| n.starts_with(".null."))
        .collect();
    assert!(left.is_empty(), "temporaries in /dev: {left:?}");
}

#[test]
fn a_fifo_as_an_output_is_refused_and_stays_a_fifo() {
    let dir = TempDir::new("fifo");
    let scene = dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let fifo = dir.join("pos.txt");
    let made = Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("run mkfifo");
    assert!(made.success(), "mkfifo failed");
    let out = wgcloth(&["run", path_str(&scene), "--positions-out", path_str(&fifo)]);
    assert_status(&out, EXIT_INVALID);
    assert_mentions(
        &out,
        &["pos.txt: is a FIFO (named pipe), not a regular file"],
    );
    let meta = fs::symlink_metadata(&fifo).expect("the FIFO");
    assert!(meta.file_type().is_fifo(), "the FIFO was replaced");
    assert_eq!(dir.files(), ["pos.txt", "small.toml"]);
}

#[test]
fn a_replaced_private_file_stays_private() {
    let dir = TempDir::new("private");
    let scene = dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let positions = dir.write("pos.txt", "old\n");
    fs::set_permissions(&positions, fs::Permissions::from_mode(0o600)).expect("chmod");
    let out = wgcloth(&[
        "run",
        path_str(&scene),
        "--positions-out",
        path_str(&positions),
    ]);
    assert_status(&out, 0);
    let text = fs::read_to_string(&positions).expect("the positions");
    assert_eq!(text.lines().count(), SMALL_PARTICLES, "not replaced");
    let mode = fs::metadata(&positions)
        .expect("metadata")
        .permissions()
        .mode();
    assert_eq!(mode & 0o7777, 0o600, "mode {mode:o}");
    assert_eq!(dir.files(), ["pos.txt", "small.toml"]);
}

/// `--positions-out` fits under the file size limit, `--trace-out` does
/// not: the old positions file stays as it was and no new file appears.
#[test]
fn a_failing_second_output_leaves_the_first_untouched() {
    let dir = TempDir::new("second-fails");
    dir.write("medium.toml", &cloth_scene(MEDIUM_SIDE));
    let run = "\"$BIN\" run medium.toml --positions-out pos.txt --trace-out trace.csv \
               --trace-every 1000";
    // Unlimited first, to measure the two outputs.
    assert_status(&bash(&dir, &format!("exec {run}")), 0);
    let size = |name: &str| fs::metadata(dir.join(name)).expect(name).len();
    let (positions, trace) = (size("pos.txt"), size("trace.csv"));
    let limit_blocks = (positions + trace) / 2 / 1024;
    assert!(
        positions < limit_blocks * 1024 && limit_blocks * 1024 < trace,
        "no limit between {positions} and {trace} bytes"
    );

    let old = dir.write("pos.txt", "old positions\n");
    fs::remove_file(dir.join("trace.csv")).expect("remove the trace");
    let out = bash(&dir, &format!("ulimit -f {limit_blocks} && exec {run}"));
    assert_status(&out, EXIT_FAILURE);
    assert_mentions(&out, &["trace.csv", "File too large"]);
    assert_eq!(
        fs::read_to_string(&old).expect("pos.txt"),
        "old positions\n"
    );
    assert_eq!(dir.files(), ["medium.toml", "pos.txt"]);
}

/// Not one byte can be written: the first frame fails, its message names
/// it, and nothing is left but whole frames (none).
#[test]
fn render_on_a_full_disk_names_the_frame_and_leaves_no_temporary() {
    let dir = TempDir::new("render-full");
    dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let out = bash(
        &dir,
        "ulimit -f 0 && exec \"$BIN\" render small.toml --out frames --frames 3 \
         --size 64x48 --adapter llvmpipe",
    );
    assert_status(&out, EXIT_FAILURE);
    assert_mentions(&out, &["frame_00000.png", "File too large"]);
    let frames = dir.join("frames");
    assert_eq!(decoded_frames(&frames, 64, 48), Vec::<String>::new());
    assert_eq!(hidden(&frames), Vec::<String>::new());
}

/// The frames of an earlier render that `--overwrite` rows plant.
const OLD_FRAMES: [&str; 2] = ["frame_00000.png", "frame_00001.png"];

/// Creates `frames` holding [`OLD_FRAMES`], each `old frame`.
fn plant_old_frames(frames: &Path) {
    fs::create_dir(frames).expect("create the frame folder");
    for name in OLD_FRAMES {
        fs::write(frames.join(name), "old frame").expect("write an old frame");
    }
}

/// Every one of [`OLD_FRAMES`] is still in `frames`, unchanged.
#[track_caller]
fn assert_old_frames_kept(frames: &Path) {
    for name in OLD_FRAMES {
        assert_eq!(
            fs::read_to_string(frames.join(name)).expect(name),
            "old frame"
        );
    }
}

/// `--overwrite` where not one byte can be written: the probe fails before
/// the old frames are removed.
#[test]
fn overwrite_keeps_the_old_frames_where_nothing_can_be_written() {
    let dir = TempDir::new("overwrite-full");
    dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let frames = dir.join("frames");
    plant_old_frames(&frames);
    let out = bash(
        &dir,
        "ulimit -f 0 && exec \"$BIN\" render small.toml --out frames --overwrite \
         --frames 1 --size 64x48 --adapter llvmpipe",
    );
    assert_status(&out, EXIT_FAILURE);
    assert_mentions(&out, &["frames", "File too large"]);
    assert_eq!(names_in(&frames), OLD_FRAMES);
    assert_old_frames_kept(&frames);
}

/// Spawns `args` in `dir`, stderr to `dir/stderr.txt`.
fn spawn(dir: &TempDir, args: &[&str]) -> Child {
    let err = fs::File::create(dir.join("stderr.txt")).expect("create stderr.txt");
    Command::new(BIN)
        .args(args)
        .current_dir(&dir.0)
        .stdout(Stdio::null())
        .stderr(err)
        .spawn()
        .expect("spawn the wgcloth binary")
}

/// Waits until `ready()` holds, then sends `signal` to `child` and returns
/// its exit status and stderr, and how long it took to end after the
/// signal.
fn interrupt(
    dir: &TempDir,
    mut child: Child,
    signal: &str,
    ready: impl Fn() -> bool,
) -> (i32, String, Duration) {
    let started = Instant::now();
    while !ready() {
        if let Some(status) = child.try_wait().expect("poll the child") {
            let err = fs::read_to_string(dir.join("stderr.txt")).unwrap_or_default();
            panic!("it ended ({status}) before it could be interrupted:\n{err}");
        }
        if started.elapsed() > START_TIMEOUT {
            let _ = child.kill();
            panic!("not ready after {START_TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let sent = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .expect("run kill");
    assert!(sent.success(), "kill {signal} failed");
    let signalled = Instant::now();
    let status = child.wait().expect("wait for the child");
    let took = signalled.elapsed();
    let err = fs::read_to_string(dir.join("stderr.txt")).expect("read stderr.txt");
    let code = status
        .code()
        .unwrap_or_else(|| panic!("killed by the signal ({status}):\n{err}"));
    (code, err, took)
}

#[test]
fn an_interrupted_render_leaves_whole_frames_and_no_temporary() {
    /// Far more frames than lavapipe renders before the test interrupts.
    const FRAMES: usize = 2000;
    let dir = TempDir::new("render-interrupted");
    dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let frames = dir.join("frames");
    let child = spawn(
        &dir,
        &[
            "render",
            "small.toml",
            "--out",
            "frames",
            "--frames",
            &FRAMES.to_string(),
            "--size",
            "64x48",
            "--adapter",
            LAVAPIPE,
        ],
    );
    let written = || {
        fs::read_dir(&frames).map_or(0, |d| {
            d.filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.file_name().to_string_lossy().starts_with("frame_"))
            })
            .count()
        })
    };
    let (code, err, _) = interrupt(&dir, child, "-TERM", || written() >= 2);
    assert_eq!(code, EXIT_INTERRUPTED, "{err}");
    assert!(err.contains("interrupted"), "{err}");
    let decoded = decoded_frames(&frames, 64, 48);
    assert!(decoded.len() >= 2, "{decoded:?}");
    assert!(decoded.len() < FRAMES, "it was not interrupted");
    let expected: Vec<String> = (0..decoded.len())
        .map(|k| format!("frame_{k:05}.png"))
        .collect();
    assert_eq!(decoded, expected, "a gap in the frames");
    assert_eq!(hidden(&frames), Vec::<String>::new());
}

#[test]
fn an_interrupted_run_writes_nothing() {
    let dir = TempDir::new("run-interrupted");
    let child = spawn(
        &dir,
        &[
            "run",
            "hanging",
            "--steps",
            "100000000",
            "--positions-out",
            "pos.txt",
        ],
    );
    // The temporary exists once the outputs are open, so stepping is under
    // way and the handler installed.
    let (code, err, _) = interrupt(&dir, child, "-INT", || !hidden(&dir.0).is_empty());
    assert_eq!(code, EXIT_INTERRUPTED, "{err}");
    assert!(err.contains("interrupted"), "{err}");
    assert_eq!(dir.files(), ["stderr.txt"]);
}

/// An unprivileged user to run a row as where the tests run as root, whom
/// a folder's permissions do not stop: `nobody`.
const NOBODY: &str = "65534";

#[test]
fn a_read_only_folders_existing_file_is_refused_naming_the_folder() {
    let dir = TempDir::new("read-only-folder");
    let ro = dir.join("ro");
    fs::create_dir(&ro).expect("create ro");
    fs::write(ro.join("p.txt"), "old\n").expect("write ro/p.txt");
    fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).expect("chmod 555 ro");
    // As root the folder's mode would not stop anything: run as nobody.
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    let args = [
        "run",
        "hanging",
        "--steps",
        "1",
        "--positions-out",
        "ro/p.txt",
    ];
    let out = if root {
        Command::new("setpriv")
            .args(["--reuid", NOBODY, "--regid", NOBODY, "--clear-groups", BIN])
            .args(args)
            .current_dir(&dir.0)
            .output()
            .expect("run the binary through setpriv")
    } else {
        Command::new(BIN)
            .args(args)
            .current_dir(&dir.0)
            .output()
            .expect("run the binary")
    };
    fs::set_permissions(&ro, fs::Permissions::from_mode(0o755)).expect("chmod 755 ro");
    assert_status(&out, EXIT_FAILURE);
    assert_mentions(
        &out,
        &[
            "ro/p.txt",
            "its folder ro does not let this user create a file",
            "must be writable, even where the file itself exists",
        ],
    );
    assert_eq!(fs::read_to_string(ro.join("p.txt")).expect("read"), "old\n");
    assert_eq!(names_in(&ro), ["p.txt"]);
}

/// CPU time \[s\] process `pid` has used (user and system, from
/// `/proc/PID/stat` in clock ticks of 1/100 s, Linux's `USER_HZ`); zero
/// once it is gone.
fn cpu_seconds(pid: u32) -> f64 {
    let stat = fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // Fields after the command name in parentheses: utime and stime are
    // the 12th and 13th of them.
    let after = stat.rsplit_once(") ").map_or("", |(_, rest)| rest);
    let ticks: u64 = after
        .split(' ')
        .skip(11)
        .take(2)
        .filter_map(|f| f.parse::<u64>().ok())
        .sum();
    ticks as f64 / 100.0
}

/// How soon a bake must end once interrupted: it asks between rows of
/// lattice points (a few hundred distance queries, under a millisecond),
/// so the rest is the process's exit; two seconds allow a loaded machine.
const BAKE_STOP: Duration = Duration::from_secs(2);

#[test]
fn an_interrupted_collider_bake_stops_at_once_and_writes_nothing() {
    let dir = TempDir::new("bake-interrupted");
    dir.write("cube.obj", crate::CUBE_OBJ);
    dir.write("scene.toml", &crate::cube_collider_scene(crate::FINE_BAKE));
    let child = spawn(
        &dir,
        &[
            "run",
            "scene.toml",
            "--steps",
            "1",
            "--positions-out",
            "pos.txt",
        ],
    );
    // The scene parses in milliseconds: a quarter second of CPU is inside
    // the bake (about 8 s on the development machine).
    let pid = child.id();
    let (code, err, took) = interrupt(&dir, child, "-INT", || cpu_seconds(pid) >= 0.25);
    assert_eq!(code, EXIT_INTERRUPTED, "{err}");
    assert!(err.contains("interrupted"), "{err}");
    assert!(took < BAKE_STOP, "it took {took:?} to stop:\n{err}");
    assert_eq!(dir.files(), ["cube.obj", "scene.toml", "stderr.txt"]);
}

/// Exit status of a command whose standard output's reader had gone:
/// 128 + SIGPIPE, as a tool the signal ended reports.
const EXIT_CLOSED_PIPE: i32 = 141;

/// Runs `wgcloth args…` in `dir` with standard output a pipe whose reader
/// is closed before the command starts (as `| head -1` closes it once it
/// has its line).
fn wgcloth_into_closed_pipe(dir: &TempDir, args: &[&str]) -> Output {
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    Command::new(BIN)
        .args(args)
        .current_dir(&dir.0)
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .expect("run the wgcloth binary")
}

/// A closed pipe on standard output ends every printing command quietly
/// (no panic, no message) with 141, after the outputs were committed
/// whole; nothing half written is left.
#[test]
fn a_closed_stdout_ends_quietly_and_keeps_whole_outputs() {
    let dir = TempDir::new("closed-pipe");
    dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let out = wgcloth_into_closed_pipe(
        &dir,
        &[
            "run",
            "small.toml",
            "--positions-out",
            "pos.txt",
            "--trace-out",
            "trace.csv",
        ],
    );
    assert_status(&out, EXIT_CLOSED_PIPE);
    assert_eq!(stderr(&out), "", "said something");
    let positions = fs::read_to_string(dir.join("pos.txt")).expect("the positions");
    assert_eq!(positions.lines().count(), SMALL_PARTICLES);
    let trace = fs::read_to_string(dir.join("trace.csv")).expect("the trace");
    assert!(trace.ends_with('\n'), "a trace cut short");

    let out = wgcloth_into_closed_pipe(&dir, &["scenes"]);
    assert_status(&out, EXIT_CLOSED_PIPE);
    assert_eq!(stderr(&out), "", "said something");

    let out = wgcloth_into_closed_pipe(
        &dir,
        &[
            "render",
            "small.toml",
            "--out",
            "frames",
            "--frames",
            "2",
            "--size",
            "16x12",
        ],
    );
    assert_status(&out, EXIT_CLOSED_PIPE);
    assert!(!stderr(&out).contains("error"), "{}", stderr(&out));
    assert_eq!(decoded_frames(&dir.join("frames"), 16, 12).len(), 2);
    assert_eq!(hidden(&dir.0), Vec::<String>::new());
    assert_eq!(hidden(&dir.join("frames")), Vec::<String>::new());
}

/// `--overwrite` over a folder named like a frame: refused before any old
/// frame is removed (status 2, naming the folder), every old frame kept.
#[test]
fn overwrite_removes_nothing_when_one_old_frame_cannot_go() {
    let dir = TempDir::new("overwrite-folder");
    dir.write("small.toml", &cloth_scene(SMALL_SIDE));
    let frames = dir.join("frames");
    plant_old_frames(&frames);
    fs::create_dir(frames.join("frame_00002.png")).expect("a folder named like a frame");
    let out = wgcloth(&[
        "render",
        path_str(&dir.join("small.toml")),
        "--out",
        path_str(&frames),
        "--overwrite",
        "--frames",
        "1",
        "--size",
        "16x12",
    ]);
    assert_status(&out, EXIT_INVALID);
    assert_mentions(
        &out,
        &[
            "--overwrite removes only regular files, and removed none",
            "frame_00002.png: is a directory",
        ],
    );
    assert_eq!(
        names_in(&frames),
        ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    );
    assert_old_frames_kept(&frames);
}
