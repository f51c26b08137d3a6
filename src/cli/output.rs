//! Output files and their formats.
//!
//! Every output goes to a temporary file beside its destination and is
//! renamed into place only when the run succeeded, so a reader never sees a
//! half-written file and a failed run leaves nothing behind: the temporary
//! is removed when its [`AtomicFile`] is dropped uncommitted (an error, a
//! blow-up, a panic). Only a killed process (Ctrl-C, SIGKILL) can leave one,
//! named `.NAME.PID.tmp`.
//!
//! Numbers are written with Rust's `{}` for `f64`, the shortest decimal that
//! parses back to the same `f64`. An `f32` solver's values are widened to
//! `f64` first (exactly), so every file reads back exactly as `f64`s
//! whatever the precision.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use wgcloth::{Real, Vec3};

/// An output file written to a temporary and renamed into place on
/// [`AtomicFile::commit`].
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    out: BufWriter<File>,
    committed: bool,
}

impl AtomicFile {
    /// Creates the temporary for `path` (in the same directory, so the final
    /// rename cannot cross file systems). Fails before anything runs if the
    /// directory does not exist or is not writable, or `path` is a directory.
    pub fn create(path: &Path) -> wgcloth::Result<Self> {
        let io_err = |source| wgcloth::Error::Io {
            path: path.to_path_buf(),
            source,
        };
        if path.is_dir() {
            return Err(io_err(io::Error::other("is a directory, not a file")));
        }
        let name = path
            .file_name()
            .ok_or_else(|| io_err(io::Error::other("not a file name")))?;
        let tmp = path.with_file_name(format!(
            ".{}.{}.tmp",
            name.to_string_lossy(),
            std::process::id()
        ));
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(io_err)?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp,
            out: BufWriter::new(file),
            committed: false,
        })
    }

    /// Runs `write` on the buffered temporary, naming the file on error.
    pub fn write_with(
        &mut self,
        write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
    ) -> wgcloth::Result<()> {
        write(&mut self.out).map_err(|source| self.io_error(source))
    }

    /// Flushes the temporary to disk and renames it to its destination.
    pub fn commit(mut self) -> wgcloth::Result<()> {
        let done = self
            .out
            .flush()
            .and_then(|()| self.out.get_ref().sync_all())
            .and_then(|()| fs::rename(&self.tmp, &self.path));
        match done {
            Ok(()) => {
                self.committed = true;
                Ok(())
            }
            Err(source) => Err(self.io_error(source)),
        }
    }

    fn io_error(&self, source: io::Error) -> wgcloth::Error {
        wgcloth::Error::Io {
            path: self.path.clone(),
            source,
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.committed {
            // Best effort: the run already failed and says why.
            let _ = fs::remove_file(&self.tmp);
        }
    }
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

    /// Records the final state unless it was just recorded, and renames the
    /// trace into place.
    pub fn finish<R: Real>(
        mut self,
        step: u64,
        time: f64,
        x: &[Vec3<R>],
        v: &[Vec3<R>],
    ) -> wgcloth::Result<()> {
        if self.last_traced != Some(step) {
            self.record(step, time, x, v)?;
        }
        self.file.commit()
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
