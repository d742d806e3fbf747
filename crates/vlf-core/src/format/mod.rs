//! The `.vlf` light-field file: what `vlf-bake` writes and `vlf-view` reads.
//!
//! ```text
//! 0   Preamble (32 bytes): magic "VLFIELD\0", version u32, header_len u32, file_len u64,
//!                          header checksum u64
//! 32  FileHeader (bincode 2, standard config): parameters (final gather included), direction
//!     set, transform, scene summary, cameras, bake statistics, radiance encoding, texel count,
//!     section table
//! ..  sections, each 16-byte aligned: raw little-endian arrays
//!     "triangles" [FileTriangle; n] (48 B), "faces" [FileFace; n] (80 B),
//!     "irradiance" (one per atlas texel, RGB9E5 or half-float RGB),
//!     "materials" [FileMaterial] (40 B), "uvs" [FileUvs; triangles] (24 B),
//!     "textures" [FileTexture] (16 B), "texels" (half-float RGB),
//!     optional "tile_index" + "tile_radiance" (mirror tiles)
//! ```
//!
//! Every section carries a checksum (block-wise XXH64, see [`crate::hash`]) and the header one of its
//! own. [`write_atomic`] never leaves a partial file at the target; [`read`] validates every
//! length against the real file size before allocating and rejects malformed content with an
//! error naming the file last. The full byte layout, versioning policy and encoding
//! measurements are in `docs/FORMAT.md`.

pub mod disk;
mod info;
mod read;
pub mod shading;
mod source;
mod tiles;
mod validate;
mod write;

use std::io;
use std::path::{Path, PathBuf};

use crate::atomic_file;
use crate::lightfield::{DEFAULT_ENCODING, LightField, RadianceEncoding};
pub use info::{FileInfo, MemoryInfo, SectionInfo, human_bytes};
use read::{read_from, read_head};
use source::{Bytes, FileSource};
use write::encode;

/// A `.vlf` file cannot be written or read. Every message ends with the file's path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FormatError {
    /// The file cannot be opened or read.
    #[error("cannot read light-field file ({source}): {path}")]
    Read { path: PathBuf, source: io::Error },

    /// A step of the atomic write failed (the target is left as it was).
    #[error("cannot write light-field file ({step}: {source}): {path}")]
    Write {
        /// E.g. `creating temporary file .x.vlf.tmp.12.0`.
        step: String,
        path: PathBuf,
        source: io::Error,
    },

    /// The file does not start with the `.vlf` magic.
    #[error("not a vlf light-field file (it starts with {found}, not \"VLFIELD\\0\"): {path}")]
    NotVlf { found: String, path: PathBuf },

    /// The file's format version is not one this build reads.
    #[error("unsupported .vlf format version {found} (this build reads {supported}): {path}")]
    UnsupportedVersion {
        found: u32,
        supported: String,
        path: PathBuf,
    },

    /// The file is shorter than its preamble or header says.
    #[error("truncated file (expected {expected} bytes, found {found}): {path}")]
    Truncated {
        expected: u64,
        found: u64,
        path: PathBuf,
    },

    /// The file is longer than its header says.
    #[error(
        "file is longer than its header says (expected {expected} bytes, found {found}): {path}"
    )]
    TrailingData {
        expected: u64,
        found: u64,
        path: PathBuf,
    },

    /// The preamble's header length is beyond any header this format writes.
    #[error("header length {len} bytes exceeds the limit of {limit} bytes (corrupt file?): {path}")]
    HeaderTooLarge {
        len: u64,
        limit: usize,
        path: PathBuf,
    },

    /// The stored checksum of the header or of a section does not match its bytes.
    #[error(
        "checksum mismatch in {section} (stored {stored:#018x}, computed {computed:#018x}): {path}"
    )]
    Checksum {
        /// `header` or the section name.
        section: String,
        stored: u64,
        computed: u64,
        path: PathBuf,
    },

    /// The header cannot be decoded or names something this build does not know.
    #[error("corrupt header ({reason}): {path}")]
    Header { reason: String, path: PathBuf },

    /// A section table entry is inconsistent (sizes, offsets, alignment, kind, missing, …).
    #[error("section {section}: {reason}: {path}")]
    Section {
        section: String,
        reason: String,
        path: PathBuf,
    },

    /// The content is inconsistent (read) or cannot be stored (write).
    #[error("{element}: {reason}: {path}")]
    Content {
        /// E.g. `face 3`, `triangle 7`, `irradiance texel 12`, `material 2`, `parameters`.
        element: String,
        reason: String,
        path: PathBuf,
    },
}

// ----- public API ---------------------------------------------------------------------------

/// Writes `lf` to `path` atomically with the [`DEFAULT_ENCODING`]; returns the file size.
pub fn write_atomic(path: &Path, lf: &LightField) -> Result<u64, FormatError> {
    write_atomic_with(path, lf, DEFAULT_ENCODING)
}

/// Writes `lf` to `path` atomically, the light (irradiance, tile radiance) stored as
/// `encoding`; returns the file size. Texture texels are always f16.
///
/// The file is written to `.NAME.tmp.PID.N` in the target's directory (a name that never ends
/// in `.vlf`, so a stale one cannot be mistaken for output), synced, renamed over `path`, and
/// the directory is synced ([`atomic_file`]). On any error before the rename the temporary
/// file is removed and an existing `path` is untouched. A failure to sync the directory after
/// the rename is reported, but the new file is then already in place.
pub fn write_atomic_with(
    path: &Path,
    lf: &LightField,
    encoding: RadianceEncoding,
) -> Result<u64, FormatError> {
    let file = encode(lf, encoding, path)?;
    atomic_file::write(path, |out| file.write_to(out)).map_err(|e| {
        let (step, source) = e.into_step();
        FormatError::Write {
            step,
            path: path.to_owned(),
            source,
        }
    })?;
    log::debug!("wrote {} ({} bytes)", path.display(), file.len);
    Ok(file.len)
}

/// The bytes [`write_atomic_with`] would write (`path` is used in messages only).
pub fn to_bytes(
    lf: &LightField,
    encoding: RadianceEncoding,
    path: &Path,
) -> Result<Vec<u8>, FormatError> {
    let file = encode(lf, encoding, path)?;
    let mut out = Vec::with_capacity(file.len as usize);
    file.write_to(&mut out).map_err(|e| FormatError::Write {
        step: "encoding".into(),
        path: path.to_owned(),
        source: e,
    })?;
    Ok(out)
}

/// Reads and fully validates a `.vlf` file.
pub fn read(path: &Path) -> Result<LightField, FormatError> {
    let src = FileSource::open(path)?;
    read_from(&src, path)
}

/// Reads a `.vlf` file from memory (`path` is used in messages only). Never panics.
pub fn read_bytes(bytes: &[u8], path: &Path) -> Result<LightField, FormatError> {
    read_from(&Bytes(bytes), path)
}

/// Reads only the preamble, header and section table of `path` (a few KiB, however large the
/// file), and the final gather's few-byte `gather_sampling` section that completes the bake
/// parameters, and summarises them. Other sections' checksums are not verified; the header's
/// is.
pub fn describe(path: &Path) -> Result<FileInfo, FormatError> {
    let src = FileSource::open(path)?;
    describe_from(&src, path)
}

/// Like [`describe`] for a file in memory.
pub fn describe_bytes(bytes: &[u8], path: &Path) -> Result<FileInfo, FormatError> {
    describe_from(&Bytes(bytes), path)
}

fn describe_from(src: &dyn source::Source, path: &Path) -> Result<FileInfo, FormatError> {
    let head = read_head(src, path)?;
    let mut info = FileInfo::new(path, &head.preamble, &head.header, head.encoding);
    info.params = read::params_of(src, &head.header, path)?;
    Ok(info)
}
