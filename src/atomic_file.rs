//! Output files written whole, never through a link, never over a device.
//!
//! Every file the crate and its CLI write goes through [`AtomicFile`]:
//!
//! - the data goes to a temporary in the destination's directory (so the
//!   final rename cannot cross file systems), created exclusively
//!   (`create_new`, i.e. `O_CREAT | O_EXCL`, which fails on anything already
//!   there, a symbolic link included, instead of following it) under a name
//!   nobody can predict: `.NAME.PID.RANDOM.tmp`, RANDOM being 64 bits from
//!   the standard library's OS-seeded hash keys. A name already taken (a
//!   planted link, a stale temporary of a killed run) is skipped for another;
//! - a destination that exists must be a regular file: a symbolic link,
//!   FIFO, device, socket or directory is refused with
//!   [`Error::NotAFile`] before anything is written, and checked again just
//!   before the rename;
//! - a replaced file keeps its permission bits;
//! - [`AtomicFile::commit`] syncs the temporary and renames it into place;
//!   dropped uncommitted (an error, an interruption, a panic), the
//!   temporary is removed. Only a killed process can leave one behind, and
//!   it never blocks a later run.
//!
//! [`commit_all`] commits several files together: every new file appears,
//! or none does and every old one stays as it was.

use std::collections::hash_map::RandomState;
use std::fs::{self, File, OpenOptions, Permissions};
use std::hash::{BuildHasher, Hasher};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Names tried for one temporary before giving up. Each is 64 random bits,
/// so a second try is only needed when someone planted that exact name; the
/// bound keeps a directory that answers "exists" to everything from
/// looping forever.
const NAME_ATTEMPTS: u32 = 16;

/// At most this many characters of the destination's name appear in a
/// temporary's name, so that the prefix, PID and random suffix (38 bytes
/// at most) keep a long name within the usual 255-byte limit.
const SHOWN_NAME_CHARS: usize = 100;

/// The name [`probe_dir`] creates its probe under (as a temporary's
/// destination; nothing of that name is ever created).
const PROBE_NAME: &str = "wgcloth-write-probe";

/// Bytes [`probe_dir`] writes: one block of a usual file system, so a disk
/// (or a file size limit) that cannot take one block is caught, while the
/// probe stays negligible next to a frame.
const PROBE_BYTES: usize = 4096;

/// An output file written to a temporary and renamed into place on
/// [`AtomicFile::commit`] (or [`commit_all`]).
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    out: BufWriter<File>,
    /// Set once `tmp` has been renamed away, so that drop leaves it alone.
    committed: bool,
}

impl AtomicFile {
    /// Checks `path` (nothing there, or a regular file) and creates its
    /// temporary. Fails before anything is written if the directory does
    /// not exist or is not writable, or `path` is not a regular file.
    pub fn create(path: &Path) -> Result<Self> {
        let existing = existing_permissions(path)?;
        let (tmp, file) = create_temporary(path, existing.as_ref())?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp,
            out: BufWriter::new(file),
            committed: false,
        })
    }

    /// The destination.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Runs `write` on the buffered temporary, naming the destination on
    /// error.
    pub fn write_with(
        &mut self,
        write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
    ) -> Result<()> {
        write(&mut self.out).map_err(|source| io_error(&self.path, source))
    }

    /// Flushes the temporary to disk and renames it to its destination.
    pub fn commit(self) -> Result<()> {
        commit_all(vec![self])
    }

    /// Flushes and syncs the temporary, checks the destination again and
    /// gives the temporary the permissions of the file it replaces.
    fn finish(&mut self) -> Result<()> {
        self.out
            .flush()
            .and_then(|()| self.out.get_ref().sync_all())
            .map_err(|source| io_error(&self.path, source))?;
        if let Some(permissions) = existing_permissions(&self.path)? {
            self.out
                .get_ref()
                .set_permissions(kept(permissions))
                .map_err(|source| io_error(&self.path, source))?;
        }
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.committed {
            // Best effort: whatever dropped it uncommitted says why.
            let _ = fs::remove_file(&self.tmp);
        }
    }
}

/// Commits `files` together: every temporary is written, synced and its
/// destination checked before the first rename, and if a rename still
/// fails, the destinations already renamed get their old file back (kept
/// as a hard link beside it until the group is in place) or are removed if
/// they were new. Either every new file appears or none does.
pub fn commit_all(mut files: Vec<AtomicFile>) -> Result<()> {
    for file in &mut files {
        file.finish()?;
    }
    // One file needs no backup: its rename is the commit.
    let mut backups = if files.len() > 1 {
        files
            .iter()
            .map(|f| Backup::of(&f.path))
            .collect::<Result<Vec<_>>>()?
    } else {
        Vec::new()
    };
    for k in 0..files.len() {
        if let Err(source) = fs::rename(&files[k].tmp, &files[k].path) {
            let undone = roll_back(&files[..k], &mut backups);
            let message = match undone {
                Ok(()) if k == 0 => source.to_string(),
                Ok(()) => format!("{source}; the outputs renamed before it were rolled back"),
                Err(e) => format!("{source}; rolling the other outputs back failed too: {e}"),
            };
            return Err(io_error(
                &files[k].path,
                io::Error::new(source.kind(), message),
            ));
        }
        files[k].committed = true;
    }
    Ok(())
}

/// Puts back what the renamed `files` replaced: the backup if there was an
/// old file (its rename replaces the new one in one step), else removes
/// the new file. A backup that cannot be restored is kept, and named in
/// the error.
fn roll_back(files: &[AtomicFile], backups: &mut [Option<Backup>]) -> io::Result<()> {
    let mut failed = Vec::new();
    for (file, backup) in files.iter().zip(backups) {
        let shown = file.path.display();
        let undone = match backup {
            Some(backup) => fs::rename(&backup.path, &file.path).map_err(|e| {
                backup.keep = true;
                format!(
                    "{shown}: {e} (its old file is kept as {})",
                    backup.path.display()
                )
            }),
            None => fs::remove_file(&file.path).map_err(|e| format!("{shown}: {e}")),
        };
        if let Err(e) = undone {
            failed.push(e);
        }
    }
    if failed.is_empty() {
        Ok(())
    } else {
        Err(io::Error::other(failed.join("; ")))
    }
}

/// A hard link to a destination's old file, beside it under a temporary's
/// name; removed when dropped unless `keep` is set.
#[derive(Debug)]
struct Backup {
    path: PathBuf,
    keep: bool,
}

impl Backup {
    /// Links the old file at `path`, if there is one.
    fn of(path: &Path) -> Result<Option<Backup>> {
        if existing_permissions(path)?.is_none() {
            return Ok(None);
        }
        let link = exclusive(path, |candidate| fs::hard_link(path, candidate)).map_err(|e| {
            io_error(
                path,
                io::Error::new(
                    e.kind(),
                    format!("keeping the old file until the new outputs are in place: {e}"),
                ),
            )
        })?;
        Ok(Some(Backup {
            path: link,
            keep: false,
        }))
    }
}

impl Drop for Backup {
    fn drop(&mut self) {
        if !self.keep {
            // Best effort: the new file is in place (or the old one back).
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// Proves that a file can be created and written in `dir`: creates an
/// exclusive temporary there, writes and syncs one block (4 KiB), and removes
/// it. Errors name `dir`.
pub fn probe_dir(dir: &Path) -> Result<()> {
    let (probe, mut file) = create_temporary(&dir.join(PROBE_NAME), None).map_err(|e| match e {
        Error::Io { source, .. } => io_error(dir, source),
        e => e,
    })?;
    let written = file
        .write_all(&[0; PROBE_BYTES])
        .and_then(|()| file.sync_all());
    drop(file);
    let removed = fs::remove_file(&probe);
    written.and(removed).map_err(|source| io_error(dir, source))
}

/// The permissions of the regular file at `path`; `None` if nothing is
/// there; [`Error::NotAFile`] for anything else (a symbolic link is not
/// followed: it is refused).
pub fn existing_permissions(path: &Path) -> Result<Option<Permissions>> {
    match fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_file() => Ok(Some(meta.permissions())),
        Ok(meta) => Err(Error::NotAFile {
            path: path.to_path_buf(),
            kind: kind_of(&meta.file_type()),
        }),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(io_error(path, source)),
    }
}

/// The permissions a replacement takes over from the file it replaces:
/// the read, write and execute bits; set-user-ID, set-group-ID and sticky
/// are dropped, as data the replaced file never held must not run with
/// its privileges.
fn kept(permissions: Permissions) -> Permissions {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        Permissions::from_mode(permissions.mode() & 0o777)
    }
    #[cfg(not(unix))]
    permissions
}

/// What a file that is not a regular file is, for a message.
fn kind_of(file_type: &fs::FileType) -> &'static str {
    if file_type.is_symlink() {
        return "a symbolic link";
    }
    if file_type.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        if file_type.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_block_device() {
            return "a block device";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    "a special file"
}

/// Creates a temporary for `path` exclusively, with `permissions` (those
/// of the file it will replace, so that its data is never more readable
/// than the old file's) where the platform allows.
fn create_temporary(path: &Path, permissions: Option<&Permissions>) -> Result<(PathBuf, File)> {
    let mut options = OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    if let Some(permissions) = permissions {
        use std::os::unix::fs::{OpenOptionsExt as _, PermissionsExt as _};
        options.mode(kept(permissions.clone()).mode());
    }
    #[cfg(not(unix))]
    let _ = permissions;
    let mut file = None;
    let tmp = exclusive(path, |candidate| {
        file = Some(options.open(candidate)?);
        Ok(())
    })
    .map_err(|source| io_error(path, unwritable_folder(path, source)))?;
    match file {
        Some(file) => Ok((tmp, file)),
        None => Err(io_error(path, io::Error::other("no temporary was created"))),
    }
}

/// Runs `make` on fresh temporary names for `path` until one does not
/// exist yet (at most [`NAME_ATTEMPTS`]); returns the name it made.
/// `make` must fail with [`io::ErrorKind::AlreadyExists`] on a taken name
/// without touching what is there.
fn exclusive(path: &Path, mut make: impl FnMut(&Path) -> io::Result<()>) -> io::Result<PathBuf> {
    for _ in 0..NAME_ATTEMPTS {
        let candidate = temporary_name(path)?;
        match make(&candidate) {
            Ok(()) => return Ok(candidate),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(io::Error::new(
        io::ErrorKind::AlreadyExists,
        format!("{NAME_ATTEMPTS} random temporary names in a row were taken"),
    ))
}

/// `.NAME.PID.RANDOM.tmp` beside `path`.
fn temporary_name(path: &Path) -> io::Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::other("not a file name"))?
        .to_string_lossy();
    let shown: String = name.chars().take(SHOWN_NAME_CHARS).collect();
    // SipHash under keys the standard library draws from the OS once per
    // thread and steps for every `RandomState`: unpredictable, and
    // different at every call.
    let random = RandomState::new().build_hasher().finish();
    Ok(path.with_file_name(format!(".{shown}.{}.{random:016x}.tmp", std::process::id())))
}

/// `source`, a failure to create the temporary beside `path`, in the
/// user's words where the folder refused it: an output that exists and is
/// writable itself is still refused in a folder that lets no file be
/// created, and "Permission denied" alone points at the file.
fn unwritable_folder(path: &Path, source: io::Error) -> io::Error {
    if source.kind() != io::ErrorKind::PermissionDenied {
        return source;
    }
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.display().to_string(),
        _ => ".".to_string(),
    };
    io::Error::new(
        io::ErrorKind::PermissionDenied,
        format!(
            "its folder {folder} does not let this user create a file ({source}): an output \
             is written whole to a temporary beside it and renamed into place, so its folder \
             must be writable, even where the file itself exists and is; choose a writable \
             folder"
        ),
    )
}

fn io_error(path: &Path, source: io::Error) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_that_refuses_the_temporary_is_named_as_the_cause() {
        let denied = io::Error::from(io::ErrorKind::PermissionDenied);
        let e = unwritable_folder(Path::new("ro/p.txt"), denied).to_string();
        assert!(
            e.contains("its folder ro does not let this user create a file")
                && e.contains("must be writable, even where the file itself exists"),
            "{e}"
        );
        let other = io::Error::from(io::ErrorKind::NotFound);
        let e = unwritable_folder(Path::new("p.txt"), other).to_string();
        assert!(!e.contains("folder"), "{e}");
    }

    /// A fresh directory for one test, removed afterwards.
    struct Dir(PathBuf);

    impl Dir {
        fn new(test: &str) -> Dir {
            let dir =
                std::env::temp_dir().join(format!("wgcloth-atomic-{}-{test}", std::process::id()));
            let _ = fs::remove_dir_all(&dir);
            fs::create_dir_all(&dir).expect("create the test directory");
            Dir(dir)
        }

        fn names(&self) -> Vec<String> {
            let mut names: Vec<String> = fs::read_dir(&self.0)
                .expect("list the test directory")
                .map(|e| {
                    e.expect("an entry")
                        .file_name()
                        .to_string_lossy()
                        .into_owned()
                })
                .collect();
            names.sort();
            names
        }
    }

    impl Drop for Dir {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    fn write(path: &Path, text: &str) -> AtomicFile {
        let mut file = AtomicFile::create(path).expect("create the temporary");
        file.write_with(|out| out.write_all(text.as_bytes()))
            .expect("write the temporary");
        file
    }

    #[test]
    fn temporary_names_differ_and_keep_the_destination_visible() {
        let path = Path::new("dir/positions.txt");
        let a = temporary_name(path).expect("a name");
        let b = temporary_name(path).expect("a name");
        assert_ne!(a, b, "two temporaries got the same name");
        let a = a.to_string_lossy();
        assert!(a.starts_with("dir/.positions.txt."), "{a}");
        assert!(a.ends_with(".tmp"), "{a}");
        let long = "x".repeat(300);
        let name = temporary_name(Path::new(&long)).expect("a name");
        assert!(name.as_os_str().len() <= 255, "{}", name.display());
    }

    #[cfg(unix)]
    #[test]
    fn a_taken_name_is_skipped_without_touching_what_is_there() {
        let dir = Dir::new("taken");
        let victim = dir.0.join("victim.txt");
        fs::write(&victim, "keep me").expect("write the victim");
        let mut tried = Vec::new();
        let made = exclusive(&dir.0.join("out.txt"), |candidate| {
            if tried.is_empty() {
                std::os::unix::fs::symlink(&victim, candidate).expect("plant a link");
            }
            tried.push(candidate.to_path_buf());
            OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(candidate)?
                .write_all(b"new")
        })
        .expect("a second name");
        assert_eq!(tried.len(), 2, "tried {tried:?}");
        assert_eq!(made, tried[1]);
        assert_eq!(fs::read_to_string(&victim).expect("the victim"), "keep me");
    }

    #[test]
    fn dropped_uncommitted_leaves_nothing() {
        let dir = Dir::new("dropped");
        drop(write(&dir.0.join("out.txt"), "new"));
        assert_eq!(dir.names(), Vec::<String>::new());
    }

    #[test]
    fn a_failed_rename_rolls_the_group_back() {
        let dir = Dir::new("rollback");
        let (old, new) = (dir.0.join("old.txt"), dir.0.join("new.txt"));
        fs::write(&old, "old").expect("write the old file");
        let files = vec![
            write(&old, "replaced"),
            write(&new, "created"),
            write(&dir.0.join("third.txt"), "third"),
        ];
        // The third file's temporary vanishes, so its rename fails after
        // the first two renames.
        fs::remove_file(&files[2].tmp).expect("remove a temporary");
        let err = commit_all(files).expect_err("the third rename fails");
        let message = err.to_string();
        assert!(message.contains("third.txt"), "{message}");
        assert_eq!(fs::read_to_string(&old).expect("the old file"), "old");
        assert_eq!(dir.names(), ["old.txt"], "left on disk");
    }

    #[test]
    fn a_group_commits_whole_and_leaves_no_backup() {
        let dir = Dir::new("group");
        let (a, b) = (dir.0.join("a.txt"), dir.0.join("b.txt"));
        fs::write(&a, "old").expect("write the old file");
        commit_all(vec![write(&a, "new a"), write(&b, "new b")]).expect("commit");
        assert_eq!(fs::read_to_string(&a).expect("a"), "new a");
        assert_eq!(fs::read_to_string(&b).expect("b"), "new b");
        assert_eq!(dir.names(), ["a.txt", "b.txt"], "left on disk");
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_permissions_but_not_set_user_id() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = Dir::new("permissions");
        let path = dir.0.join("secret.txt");
        fs::write(&path, "old").expect("write the old file");
        fs::set_permissions(&path, Permissions::from_mode(0o4640)).expect("chmod");
        write(&path, "new").commit().expect("commit");
        let mode = fs::metadata(&path).expect("metadata").permissions().mode();
        assert_eq!(mode & 0o7777, 0o640);
        assert_eq!(fs::read_to_string(&path).expect("the file"), "new");
    }

    #[cfg(unix)]
    #[test]
    fn a_link_or_a_directory_is_refused() {
        let dir = Dir::new("refused");
        let link = dir.0.join("link.txt");
        std::os::unix::fs::symlink(dir.0.join("target.txt"), &link).expect("plant a link");
        for (path, kind) in [(&link, "a symbolic link"), (&dir.0, "a directory")] {
            match AtomicFile::create(path) {
                Err(Error::NotAFile { kind: k, .. }) => assert_eq!(k, kind),
                other => panic!("{}: {other:?}", path.display()),
            }
        }
        assert_eq!(dir.names(), ["link.txt"], "left on disk");
    }

    #[test]
    fn the_probe_fails_where_no_file_can_be_made_and_leaves_nothing() {
        let dir = Dir::new("probe");
        probe_dir(&dir.0).expect("a writable directory");
        assert_eq!(dir.names(), Vec::<String>::new());
        let missing = dir.0.join("missing");
        match probe_dir(&missing) {
            Err(Error::Io { path, .. }) => assert_eq!(path, missing),
            other => panic!("{other:?}"),
        }
    }
}
