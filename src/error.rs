//! The library's one error type.

use std::path::PathBuf;

/// Everything that can go wrong in the library. Every variant's message is
/// meant to be shown to a user as is: it names what was wrong, what is
/// allowed, and (for files) where.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A parameter is outside its admissible range.
    #[error("`{key}`: must be {allowed}, got {got}")]
    InvalidParameter {
        /// Dotted key, scene-file spelling (`springs.stretch.stiffness`).
        key: String,
        /// What is allowed, with units.
        allowed: String,
        /// What was given.
        got: String,
    },

    /// A scene file could not be read, parsed or validated.
    #[error("scene file {}: {message}", path.display())]
    Scene {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the key and what is allowed.
        message: String,
    },

    /// A built-in scene name that does not exist.
    #[error("no scene file or built-in scene named `{name}` (built-in scenes: {available})")]
    UnknownScene {
        /// The name asked for.
        name: String,
        /// Comma-separated built-in names.
        available: String,
    },

    /// The simulation state became NaN or infinite.
    #[error(
        "simulation blew up at step {step} (t = {time:.6} s): particle {particle} is not finite; \
         try a smaller dt, softer springs or another integrator"
    )]
    NonFinite {
        /// The step (1-based) after which the state was first non-finite.
        step: u64,
        /// Simulated time at that step \[s\].
        time: f64,
        /// The first non-finite particle.
        particle: usize,
    },

    /// No GPU adapter could be found or opened.
    #[error(
        "no GPU adapter: {message}. On Linux without a GPU, Mesa's software \
         Vulkan driver works: `apt-get install mesa-vulkan-drivers` (lavapipe); \
         WGPU_ADAPTER_NAME selects an adapter by name"
    )]
    NoAdapter {
        /// What failed.
        message: String,
    },

    /// A GPU adapter was found but its device could not be opened (the
    /// driver out of memory, or failing): unlike [`Error::NoAdapter`], no
    /// driver is missing.
    #[error("the GPU adapter {adapter} was found but could not be opened: {message}")]
    DeviceUnavailable {
        /// The adapter's name.
        adapter: String,
        /// Why (`out of memory …`).
        message: String,
    },

    /// The device cannot hold this cloth or image, or lacks a needed
    /// capability.
    #[error("the GPU device's limit `{limit}` is {available}, but {what} needs {needed}")]
    DeviceLimit {
        /// What needs the limit (`the cloth's largest buffer [bytes]`,
        /// `the image's width [pixels]`).
        what: String,
        /// The wgpu limit's name.
        limit: &'static str,
        /// What the device offers.
        available: u64,
        /// What it needs.
        needed: u64,
    },

    /// A wgpu operation failed (validation, out of memory, lost device).
    #[error("GPU error: {0}")]
    Gpu(String),

    /// An I/O error on an output or input file.
    #[error("{}", path.display())]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },

    /// An output's destination exists and is not a regular file: outputs
    /// never replace or write through a symbolic link, device, FIFO, socket
    /// or directory.
    #[error(
        "{}: is {kind}, not a regular file; outputs are only written to regular files \
         (never through a symbolic link, nor over a device, FIFO, socket or directory): \
         choose another path",
        path.display()
    )]
    NotAFile {
        /// The destination.
        path: PathBuf,
        /// What is there (`a FIFO (named pipe)`, `a symbolic link`, …).
        kind: &'static str,
    },

    /// The caller asked the work to stop (the CLI: Ctrl-C or SIGTERM)
    /// before it was done. Files already complete stay; no partial file is
    /// left.
    #[error("interrupted before the work was done")]
    Interrupted,

    /// A scene, its solver or its image needs more memory than the host or
    /// the GPU device can give: refused before it is allocated (see
    /// [`crate::budget`]), or refused by the allocator or the device when
    /// an allocation the estimate allowed still failed.
    #[error("{what} needs {}, but {limit}", crate::budget::Bytes::of(.needed))]
    OutOfMemory {
        /// What needs the memory.
        what: String,
        /// What it needs \[bytes\].
        needed: u64,
        /// What the limit allows \[bytes\], when known.
        available: Option<u64>,
        /// The limit, as a clause (`the host has 2.0 GiB available
        /// (MemAvailable in /proc/meminfo)`).
        limit: String,
    },

    /// The simulation state is finite but has diverged: it crossed a bound
    /// of [`crate::diagnostics::Divergence`].
    #[error(
        "simulation blew up at step {step} (t = {time:.6} s): {crossed}; \
         try a smaller dt, softer springs or another integrator"
    )]
    Diverged {
        /// The step (1-based) after which the bound was found crossed.
        step: u64,
        /// Simulated time at that step \[s\].
        time: f64,
        /// The bound crossed, with the numbers.
        crossed: crate::diagnostics::Crossed,
    },

    /// A cloth's mesh file (`[cloth] mesh`) could not be read, parsed or
    /// used: nothing was built from it.
    #[error("mesh file {}: {message}", path.display())]
    Mesh {
        /// The mesh file.
        path: PathBuf,
        /// What is wrong: where (an OBJ line, a glTF JSON path, a face) and
        /// what is allowed.
        message: String,
    },

    /// What went wrong with one cloth of a
    /// [`GpuBatch`](crate::gpu::GpuBatch) (its state stopped being finite,
    /// its read-back failed), the error itself as its source (shown after
    /// it by `{:#}` and error reporters, as [`Error::Io`]'s is).
    #[error("cloth {cloth} of the batch")]
    InBatch {
        /// The cloth's index ([`ClothId::index`](crate::gpu::ClothId::index)).
        cloth: u32,
        /// What went wrong.
        source: Box<Error>,
    },
}

/// `Result` with the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
