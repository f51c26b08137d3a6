//! Compiled pipelines kept between runs: wgpu's pipeline cache (Vulkan
//! only, [`wgpu::Features::PIPELINE_CACHE`]) in a file per adapter.
//!
//! The file is `DIR/KEY.bin`, `KEY` being [`wgpu::util::pipeline_cache_key`]
//! of the adapter (vendor and device), and holds what
//! [`wgpu::PipelineCache::get_data`] returned behind a header of ours: a
//! magic word, the data's length and its FNV-1a checksum. A file that is
//! missing, unreadable, truncated, altered or written for another adapter
//! is ignored (wgpu checks the adapter, driver and version in its own
//! header, and falls back to an empty cache for data it cannot use); the
//! run then compiles its pipelines afresh and writes a new file. The file
//! is written atomically ([`crate::atomic_file`]), so a reader never sees
//! half of one.

use std::path::{Path, PathBuf};

use crate::atomic_file::AtomicFile;
use crate::error::{Error, Result};

/// The first bytes of a cache file.
const MAGIC: [u8; 8] = *b"wgclothP";
/// Bytes of the header: magic, data length, checksum.
const HEADER: usize = 24;

/// The folder the CLI keeps its cache in: `$XDG_CACHE_HOME/wgcloth`, else
/// `$HOME/.cache/wgcloth`; `None` when neither variable is set to an
/// absolute path.
pub fn default_dir() -> Option<PathBuf> {
    let absolute = |var: &str| {
        std::env::var_os(var)
            .map(PathBuf::from)
            .filter(|p| p.is_absolute())
    };
    absolute("XDG_CACHE_HOME")
        .or_else(|| absolute("HOME").map(|h| h.join(".cache")))
        .map(|d| d.join("wgcloth"))
}

/// The cache file of the adapter `info` in `dir`; `None` on a backend
/// without a pipeline cache.
pub fn file(dir: &Path, info: &wgpu::AdapterInfo) -> Option<PathBuf> {
    wgpu::util::pipeline_cache_key(info).map(|key| dir.join(format!("{key}.bin")))
}

/// FNV-1a, 64 bits: detects a damaged file (not a forged one).
fn checksum(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The data a cache file holds, if it is one this module wrote intact.
pub(crate) fn decode(bytes: &[u8]) -> Option<&[u8]> {
    if bytes.len() < HEADER || bytes[..8] != MAGIC {
        return None;
    }
    let word = |at: usize| {
        let mut w = [0u8; 8];
        w.copy_from_slice(&bytes[at..at + 8]);
        u64::from_le_bytes(w)
    };
    let data = &bytes[HEADER..];
    (word(8) == data.len() as u64 && word(16) == checksum(data)).then_some(data)
}

/// `data` with the header [`decode`] checks.
pub(crate) fn encode(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + data.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&(data.len() as u64).to_le_bytes());
    out.extend_from_slice(&checksum(data).to_le_bytes());
    out.extend_from_slice(data);
    out
}

/// The data of the cache file at `path`, or `None` when there is none
/// this module wrote intact (a missing or unreadable file is no error:
/// the run only compiles afresh).
pub(crate) fn load(path: &Path) -> Option<Vec<u8>> {
    let bytes = std::fs::read(path).ok()?;
    decode(&bytes).map(<[u8]>::to_vec)
}

/// Writes `data` to `path` atomically, creating its folder.
pub(crate) fn save(path: &Path, data: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let mut file = AtomicFile::create(path)?;
    let bytes = encode(data);
    file.write_with(|w| std::io::Write::write_all(w, &bytes))?;
    file.commit()
}

/// A pipeline cache on `device` seeded with `data`, when the device has
/// the feature.
pub(crate) fn create(device: &wgpu::Device, data: Option<&[u8]>) -> Option<wgpu::PipelineCache> {
    if !device.features().contains(wgpu::Features::PIPELINE_CACHE) {
        return None;
    }
    let desc = wgpu::PipelineCacheDescriptor {
        label: Some("wgcloth.pipeline_cache"),
        data,
        fallback: true,
    };
    // SAFETY: wgpu requires `data` to come from `PipelineCache::get_data`.
    // It does: `load` returns only what `save` wrote (magic, length and
    // checksum intact), and `save` is given only `get_data`'s output;
    // wgpu itself checks that the data was made for this adapter, driver
    // and wgpu version, and with `fallback` starts empty when it was not.
    #[expect(unsafe_code, reason = "wgpu's pipeline cache constructor is unsafe")]
    let cache = unsafe { device.create_pipeline_cache(&desc) };
    Some(cache)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_damaged_file_is_not_taken_for_a_cache() {
        let data: Vec<u8> = (0..200u8).collect();
        let good = encode(&data);
        assert_eq!(decode(&good), Some(&data[..]));
        let mut flipped = good.clone();
        flipped[HEADER + 17] ^= 1;
        assert_eq!(decode(&flipped), None);
        assert_eq!(decode(&good[..good.len() - 1]), None);
        assert_eq!(decode(&good[..10]), None);
        let mut foreign = good;
        foreign[0] = b'x';
        assert_eq!(decode(&foreign), None);
    }
}
