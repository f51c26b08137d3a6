//! A glTF buffer's external `uri`: a relative URI reference, percent-encoded
//! (RFC 3986), resolved against the mesh file's folder and confined to it.
//!
//! A mesh reads only its own files: a scene or mesh from someone else must
//! not read `/etc/passwd` into the cloth (where `--positions-out` would write
//! its bytes back). So the decoded path must be relative, its `..` may not
//! climb above the folder, and the file it names, once every symbolic link
//! on the way is followed, must still lie in the folder or below it.

use std::path::{Component, Path, PathBuf};

/// The file `uri` names in `folder` (canonical, every link followed), or
/// why it may not be read. `data:` URIs are decoded by the caller.
pub(super) fn resolve(folder: &Path, uri: &str) -> Result<PathBuf, String> {
    let allowed = "a mesh reads only files in its own folder and below it: give a relative \
                   path such as `mesh.bin` (percent-encoded, as a URI is), or embed the data as \
                   a base64 `data:` URI";
    if let Some(scheme) = scheme(uri) {
        return Err(format!("`{uri}` is a `{scheme}:` URI; {allowed}"));
    }
    let decoded = percent_decode(uri)?;
    let relative = Path::new(&decoded);
    let mut depth = 0usize;
    for component in relative.components() {
        match component {
            Component::Prefix(_) | Component::RootDir => {
                return Err(format!("`{decoded}` is an absolute path; {allowed}"));
            }
            Component::CurDir => {}
            Component::Normal(_) => depth += 1,
            Component::ParentDir => {
                depth = depth.checked_sub(1).ok_or_else(|| {
                    format!("`{decoded}`: its `..` leads out of the mesh's folder; {allowed}")
                })?;
            }
        }
    }
    let folder = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let joined = folder.join(relative);
    let cannot = |path: &Path, e: std::io::Error| format!("cannot read {}: {e}", path.display());
    let home = folder.canonicalize().map_err(|e| cannot(folder, e))?;
    let real = joined.canonicalize().map_err(|e| cannot(&joined, e))?;
    if !real.starts_with(&home) {
        return Err(format!(
            "`{decoded}` is (or goes through) a symbolic link to {}, outside the mesh's folder \
             {}; {allowed}",
            real.display(),
            home.display()
        ));
    }
    Ok(real)
}

/// The scheme of an absolute URI (`file`, `http`), if `uri` has one: an
/// ASCII letter, then letters, digits, `+`, `-` or `.`, then `:` (RFC 3986
/// §3.1; a relative reference cannot have a `:` in its first segment).
fn scheme(uri: &str) -> Option<&str> {
    let (scheme, _) = uri.split_once(':')?;
    let mut chars = scheme.chars();
    let first = chars.next()?;
    (first.is_ascii_alphabetic()
        && chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.')))
    .then_some(scheme)
}

/// `uri` with each `%XX` replaced by the byte it encodes; the bytes must
/// be UTF-8, as a glTF string is.
fn percent_decode(uri: &str) -> Result<String, String> {
    let raw = uri.as_bytes();
    let mut bytes = Vec::with_capacity(raw.len());
    let mut k = 0;
    while k < raw.len() {
        if raw[k] == b'%' {
            let byte = raw
                .get(k + 1..k + 3)
                .and_then(|hex| std::str::from_utf8(hex).ok())
                .and_then(|hex| u8::from_str_radix(hex, 16).ok())
                .ok_or_else(|| {
                    format!(
                        "`{uri}`: a `%` at byte {k} is not followed by two hexadecimal digits; \
                         a URI writes a byte as `%XX` (a space is `%20`, a `%` is `%25`)"
                    )
                })?;
            bytes.push(byte);
            k += 3;
        } else {
            bytes.push(raw[k]);
            k += 1;
        }
    }
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "`{uri}`: its percent-decoded bytes are not UTF-8 (byte {} is not valid)",
            e.utf8_error().valid_up_to()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_escapes_decode_to_their_bytes() {
        assert_eq!(
            percent_decode("mesh%20sp.bin").as_deref(),
            Ok("mesh sp.bin")
        );
        assert_eq!(percent_decode("a%2fb%25").as_deref(), Ok("a/b%"));
        assert_eq!(percent_decode("caf%C3%A9").as_deref(), Ok("café"));
        assert_eq!(percent_decode("plain.bin").as_deref(), Ok("plain.bin"));
        for bad in ["a%2", "a%zz.bin", "%", "%C3"] {
            assert!(percent_decode(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn only_a_uri_with_a_scheme_has_one() {
        assert_eq!(scheme("file:///etc/passwd"), Some("file"));
        assert_eq!(scheme("http://x/y.bin"), Some("http"));
        assert_eq!(scheme("svn+ssh:x"), Some("svn+ssh"));
        for relative in ["mesh.bin", "./a:b.bin", "sub/a:b", "1a:b", ":x"] {
            assert_eq!(scheme(relative), None, "{relative}");
        }
    }

    #[test]
    fn paths_that_leave_the_folder_are_refused_before_any_file_is_touched() {
        // The folder does not exist: these fail on their text alone.
        let folder = Path::new("/nonexistent-wgcloth-folder");
        for (uri, says) in [
            ("/etc/passwd", "absolute path"),
            ("%2Fetc%2Fpasswd", "absolute path"),
            ("../secret.bin", "leads out"),
            ("a/../../secret.bin", "leads out"),
            ("%2E%2E/secret.bin", "leads out"),
            ("file:///etc/passwd", "`file:` URI"),
        ] {
            let e = resolve(folder, uri).err().unwrap_or_default();
            assert!(e.contains(says), "{uri}: {e}");
            assert!(e.contains("its own folder"), "{uri}: {e}");
        }
    }
}
