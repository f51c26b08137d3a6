//! PNG frames written by a thread of their own, so encoding one frame
//! overlaps the device simulating and rendering the next.
//!
//! Each file is written whole by [`AtomicFile`]: to an exclusive temporary
//! beside it, renamed into place when complete, so a reader never sees half
//! a frame and nothing is written through a planted link.

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;

use crate::atomic_file::AtomicFile;
use crate::error::{Error, Result};

/// Frames queued for the writer at most; a slower disk holds the renderer
/// back instead of filling memory.
pub(super) const QUEUE: usize = 4;

/// One frame's pixels: tightly packed RGBA8 rows, top row first.
#[derive(Debug)]
pub struct Frame {
    /// Where the PNG goes.
    pub path: PathBuf,
    /// Width \[pixels\].
    pub width: u32,
    /// Height \[pixels\].
    pub height: u32,
    /// `width × height × 4` bytes.
    pub rgba: Vec<u8>,
}

/// The name of frame `index` in a frame folder: `frame_00000.png`.
pub fn frame_name(index: u32) -> String {
    format!("frame_{index:05}.png")
}

/// Whether `name` is a frame file's name (`frame_*.png`).
pub fn is_frame_name(name: &str) -> bool {
    name.starts_with("frame_") && name.ends_with(".png")
}

/// The frame files (`frame_*.png`) in `dir`, sorted; none if `dir` does not
/// exist.
pub fn existing_frames(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = match fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(source) => return Err(io_error(dir, source)),
    };
    let mut frames = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| io_error(dir, e))?;
        if entry.file_name().to_str().is_some_and(is_frame_name) {
            frames.push(entry.path());
        }
    }
    frames.sort();
    Ok(frames)
}

/// Removes the frame files (`frame_*.png`) in `dir`, nothing else. Every
/// one is checked to be a regular file first: a folder, link or other
/// special file by a frame's name is [`Error::NotAFile`] and nothing is
/// removed, so that the old frames are never lost to a removal that
/// cannot finish.
pub fn remove_frames(dir: &Path) -> Result<usize> {
    let frames = existing_frames(dir)?;
    for f in &frames {
        crate::atomic_file::existing_permissions(f)?;
    }
    for f in &frames {
        fs::remove_file(f).map_err(|e| io_error(f, e))?;
    }
    Ok(frames.len())
}

/// Writes `frame` as an 8-bit RGBA PNG, whole: through an [`AtomicFile`].
pub fn write_png(frame: &Frame) -> Result<()> {
    let mut file = AtomicFile::create(&frame.path)?;
    file.write_with(|out| encode(frame, out))?;
    file.commit()
}

fn encode(frame: &Frame, out: &mut impl Write) -> io::Result<()> {
    let mut encoder = png::Encoder::new(out, frame.width, frame.height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(png_io)?;
    writer.write_image_data(&frame.rgba).map_err(png_io)?;
    writer.finish().map_err(png_io)
}

/// The encoder's error as an I/O error, keeping the kind of one that came
/// from the file (a full disk stays "no space left on device").
fn png_io(e: png::EncodingError) -> io::Error {
    match e {
        png::EncodingError::IoError(e) => e,
        e => io::Error::other(e),
    }
}

fn io_error(path: &Path, source: io::Error) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// A thread that writes the frames sent to it, in order.
#[derive(Debug)]
pub struct PngWriter {
    tx: Option<flume::Sender<Frame>>,
    thread: Option<JoinHandle<Result<u32>>>,
}

impl PngWriter {
    /// Starts the thread.
    pub fn spawn() -> Result<PngWriter> {
        let (tx, rx) = flume::bounded::<Frame>(QUEUE);
        let thread = std::thread::Builder::new()
            .name("wgcloth-png".into())
            .spawn(move || {
                let mut written = 0;
                for frame in rx {
                    write_png(&frame)?;
                    written += 1;
                }
                Ok(written)
            })
            .map_err(|e| Error::Gpu(format!("starting the PNG writer thread: {e}")))?;
        Ok(PngWriter {
            tx: Some(tx),
            thread: Some(thread),
        })
    }

    /// Queues `frame` (waits while the queue is full). If the thread has
    /// stopped on an error, returns that error.
    pub fn send(&mut self, frame: Frame) -> Result<()> {
        let sent = self.tx.as_ref().map(|tx| tx.send(frame).is_ok());
        if sent == Some(true) {
            Ok(())
        } else {
            // The receiver is gone: the thread returned its error.
            self.finish().map(|_| ())
        }
    }

    /// Waits until every queued frame is written; returns how many the
    /// thread wrote, or its first error.
    pub fn finish(&mut self) -> Result<u32> {
        self.tx = None;
        match self.thread.take() {
            Some(thread) => thread
                .join()
                .map_err(|_| Error::Gpu("the PNG writer thread panicked".into()))?,
            None => Err(Error::Gpu("the PNG writer has already finished".into())),
        }
    }
}

impl Drop for PngWriter {
    fn drop(&mut self) {
        // Let the thread write what it has and stop; an error it met is
        // dropped with it (the caller that wanted it called `finish`).
        self.tx = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
