//! Output files and their formats.
//!
//! Every output is an [`AtomicFile`] (see [`wgcloth::atomic_file`]): written
//! to an exclusive temporary beside its destination, and renamed into place
//! only when the run succeeded, all of a run's outputs together
//! ([`commit_all`]); a failed or interrupted run leaves nothing behind and
//! replaces nothing.
//!
//! Numbers are written with Rust's `{}` for `f64`, the shortest decimal that
//! parses back to the same `f64`. An `f32` solver's values are widened to
//! `f64` first (exactly), so every file reads back exactly as `f64`s
//! whatever the precision.

use std::fs;
use std::io::{self, Write};
use std::path::Path;

pub use wgcloth::atomic_file::{commit_all, AtomicFile};
use wgcloth::real::{Real, Vec3};

/// Whether `a` and `b` name the same file: the same name in the same
/// directory (the directories' links resolved), or two names of one
/// existing file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    if a == b {
        return true;
    }
    let resolved = |p: &Path| {
        let dir = match p.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir,
            _ => Path::new("."),
        };
        Some((fs::canonicalize(dir).ok()?, p.file_name()?.to_owned()))
    };
    if let (Some(a), Some(b)) = (resolved(a), resolved(b)) {
        if a == b {
            return true;
        }
    }
    #[cfg(unix)]
    if let (Ok(a), Ok(b)) = (fs::metadata(a), fs::metadata(b)) {
        use std::os::unix::fs::MetadataExt as _;
        return (a.dev(), a.ino()) == (b.dev(), b.ino());
    }
    false
}

/// Refuses two of a command's outputs (`--option`, path; `None`: not
/// asked for) that name one file ([`same_file`]): the second would replace
/// the first, and a run must never keep one of two outputs silently.
pub fn distinct_outputs(outputs: &[(&str, Option<&Path>)]) -> Result<(), super::UsageError> {
    for (k, (a_name, a)) in outputs.iter().enumerate() {
        for (b_name, b) in &outputs[k + 1..] {
            if let (Some(a), Some(b)) = (a, b) {
                if same_file(a, b) {
                    return Err(super::UsageError(format!(
                        "{a_name} and {b_name} are the same file ({}); give each its own file",
                        a.display()
                    )));
                }
            }
        }
    }
    Ok(())
}

/// `--positions-out`: one line `x y z` per particle, in particle order.
pub fn write_positions<R: Real>(out: &mut impl Write, x: &[Vec3<R>]) -> io::Result<()> {
    for p in x {
        let [x, y, z] = p.to_f64();
        writeln!(out, "{x} {y} {z}")?;
    }
    Ok(())
}

/// The header line of `--trace-out`.
pub const TRACE_HEADER: &str = "step,time,particle,x,y,z,vx,vy,vz";

/// `--trace-out`: a CSV trace streamed during the run, one row per particle
/// at every traced step.
pub struct Trace {
    file: AtomicFile,
    every: u64,
    last_traced: Option<u64>,
}

impl Trace {
    /// Starts the trace (header only) in a temporary beside `path`.
    pub fn create(path: &Path, every: u64) -> wgcloth::Result<Self> {
        let mut file = AtomicFile::create(path)?;
        file.write_with(|out| writeln!(out, "{TRACE_HEADER}"))?;
        Ok(Trace {
            file,
            every,
            last_traced: None,
        })
    }

    /// Whether [`Trace::step`] records `step`: a multiple of K.
    pub fn wants(&self, step: u64) -> bool {
        step.is_multiple_of(self.every)
    }

    /// Records the state after `step` if `step` is a multiple of K.
    pub fn step<R: Real>(
        &mut self,
        step: u64,
        time: f64,
        x: &[Vec3<R>],
        v: &[Vec3<R>],
    ) -> wgcloth::Result<()> {
        if self.wants(step) {
            self.record(step, time, x, v)?;
        }
        Ok(())
    }

    /// Records the final state unless it was just recorded; returns the
    /// file, for the caller to commit with the run's other outputs.
    pub fn finish<R: Real>(
        mut self,
        step: u64,
        time: f64,
        x: &[Vec3<R>],
        v: &[Vec3<R>],
    ) -> wgcloth::Result<AtomicFile> {
        if self.last_traced != Some(step) {
            self.record(step, time, x, v)?;
        }
        Ok(self.file)
    }

    fn record<R: Real>(
        &mut self,
        step: u64,
        time: f64,
        x: &[Vec3<R>],
        v: &[Vec3<R>],
    ) -> wgcloth::Result<()> {
        self.last_traced = Some(step);
        self.file.write_with(|out| {
            for (p, (x, v)) in x.iter().zip(v).enumerate() {
                let [x, y, z] = x.to_f64();
                let [vx, vy, vz] = v.to_f64();
                writeln!(out, "{step},{time},{p},{x},{y},{z},{vx},{vy},{vz}")?;
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_file_sees_through_spellings_and_links() {
        let dir = std::env::temp_dir().join(format!("wgcloth-same-{}", std::process::id()));
        fs::create_dir_all(dir.join("sub")).expect("create the test directory");
        let a = dir.join("a.txt");
        assert!(same_file(&a, &dir.join("sub/../a.txt")));
        assert!(!same_file(&a, &dir.join("b.txt")));
        fs::write(&a, "a").expect("write a file");
        fs::hard_link(&a, dir.join("sub/a2.txt")).expect("link it");
        assert!(same_file(&a, &dir.join("sub/a2.txt")));
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn positions_round_trip_exactly_in_both_precisions() {
        let x64 = [
            Vec3::new(0.1, -1.0 / 3.0, 1e-300),
            Vec3::new(-0.0, 5e7, 2.5),
        ];
        let x32 = [Vec3::new(0.1f32, -1.0 / 3.0, 1e-30)];
        let mut text = Vec::new();
        write_positions(&mut text, &x64).expect("in memory");
        write_positions(&mut text, &x32).expect("in memory");
        let parsed: Vec<f64> = String::from_utf8(text)
            .expect("utf-8")
            .split_ascii_whitespace()
            .map(|s| s.parse().expect("a number"))
            .collect();
        let expected: Vec<f64> = x64
            .iter()
            .map(|p| p.to_f64())
            .chain(x32.iter().map(|p| p.to_f64()))
            .flatten()
            .collect();
        assert_eq!(parsed.len(), expected.len());
        for (a, b) in parsed.iter().zip(&expected) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a} ≠ {b}");
        }
    }
}
