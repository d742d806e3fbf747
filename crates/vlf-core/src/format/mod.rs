//! The `.vlf` light-field file: what `vlf-bake` writes and `vlf-view` reads.
//!
//! ```text
//! 0   Preamble (32 bytes): magic "VLFIELD\0", version u32, header_len u32, file_len u64,
//!                          header checksum u64
//! 32  FileHeader (bincode 2, standard config): parameters, direction set, transform, scene
//!     summary, cameras, bake statistics, radiance encoding, texel count, section table
//! ..  sections, each 16-byte aligned: raw little-endian arrays
//!     "triangles" [FileTriangle; n] (48 B), "faces" [FileFace; n] (80 B),
//!     "radiance" (one texel per atlas texel, RGB9E5 or half-float RGB)
//! ```
//!
//! Every section carries a checksum (block-wise XXH64, see [`crate::hash`]) and the header one of its
//! own. [`write_atomic`] never leaves a partial file at the target; [`read`] validates every
//! length against the real file size before allocating and rejects malformed content with an
//! error naming the file last. The full byte layout, versioning policy and encoding
//! measurements are in `docs/FORMAT.md`.

pub mod disk;
mod info;
mod tiles;

use std::borrow::Cow;
use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use bytemuck::Pod;

use crate::directions::DirectionSet;
use crate::lightfield::{
    BakeFace, BakeParams, BakeTriangle, DEFAULT_ENCODING, FACE_MIXED, LightField, MirrorTiles,
    Radiance, RadianceEncoding,
};
use crate::{atomic_file, hash, parallel};
use disk::{
    FileCamera, FileDirections, FileFace, FileHeader, FileParams, FileSceneSummary, FileStats,
    FileTransform, FileTriangle, MAGIC, MAX_HEADER_LEN, PREAMBLE_LEN, Preamble, SECTION_ALIGN,
    SectionEntry, VERSION,
};
pub use info::{FileInfo, MemoryInfo, SectionInfo};

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
        /// E.g. `face 3`, `triangle 7`, `radiance texel 12`, `parameters`.
        element: String,
        reason: String,
        path: PathBuf,
    },
}

// ----- sources ------------------------------------------------------------------------------

/// Random-access bytes: a file or a slice. `Sync` so that threads can read blocks.
trait Source: Sync {
    fn len(&self) -> u64;
    fn read_at(&self, offset: u64, buf: &mut [u8]) -> io::Result<()>;
}

struct Bytes<'a>(&'a [u8]);

impl Source for Bytes<'_> {
    fn len(&self) -> u64 {
        self.0.len() as u64
    }
    fn read_at(&self, offset: u64, buf: &mut [u8]) -> io::Result<()> {
        let s = usize::try_from(offset)
            .ok()
            .and_then(|start| self.0.get(start..start.checked_add(buf.len())?))
            .ok_or_else(|| io::Error::from(io::ErrorKind::UnexpectedEof))?;
        buf.copy_from_slice(s);
        Ok(())
    }
}

struct FileSource {
    #[cfg(unix)]
    file: File,
    #[cfg(not(unix))]
    file: std::sync::Mutex<File>,
    len: u64,
}

impl FileSource {
    fn open(path: &Path) -> Result<Self, FormatError> {
        let err = |source| FormatError::Read {
            path: path.to_owned(),
            source,
        };
        let file = File::open(path).map_err(err)?;
        let meta = file.metadata().map_err(err)?;
        if !meta.is_file() {
            return Err(err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "not a regular file",
            )));
        }
        Ok(FileSource {
            #[cfg(unix)]
            file,
            #[cfg(not(unix))]
            file: std::sync::Mutex::new(file),
            len: meta.len(),
        })
    }
}

impl Source for FileSource {
    fn len(&self) -> u64 {
        self.len
    }
    #[cfg(unix)]
    fn read_at(&self, offset: u64, buf: &mut [u8]) -> io::Result<()> {
        std::os::unix::fs::FileExt::read_exact_at(&self.file, buf, offset)
    }
    #[cfg(not(unix))]
    fn read_at(&self, offset: u64, buf: &mut [u8]) -> io::Result<()> {
        use std::io::{Read, Seek, SeekFrom};
        let mut f = self.file.lock().unwrap_or_else(|e| e.into_inner());
        f.seek(SeekFrom::Start(offset))?;
        f.read_exact(buf)
    }
}

// ----- public API ---------------------------------------------------------------------------

/// Writes `lf` to `path` atomically with the [`DEFAULT_ENCODING`]; returns the file size.
pub fn write_atomic(path: &Path, lf: &LightField) -> Result<u64, FormatError> {
    write_atomic_with(path, lf, DEFAULT_ENCODING)
}

/// Writes `lf` to `path` atomically, radiance stored as `encoding`; returns the file size.
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
/// file) and summarises them. Section checksums are not verified; the header's is.
pub fn describe(path: &Path) -> Result<FileInfo, FormatError> {
    let src = FileSource::open(path)?;
    let head = read_head(&src, path)?;
    Ok(FileInfo::new(
        path,
        &head.preamble,
        &head.header,
        head.encoding,
    ))
}

/// Like [`describe`] for a file in memory.
pub fn describe_bytes(bytes: &[u8], path: &Path) -> Result<FileInfo, FormatError> {
    let head = read_head(&Bytes(bytes), path)?;
    Ok(FileInfo::new(
        path,
        &head.preamble,
        &head.header,
        head.encoding,
    ))
}

// ----- writing ------------------------------------------------------------------------------

/// An encoded file, ready to be written: radiance stored in the requested encoding is
/// borrowed from the light field, not copied.
struct Encoded<'a> {
    head: Vec<u8>,
    /// (offset, bytes) in file order.
    sections: Vec<(u64, Cow<'a, [u8]>)>,
    len: u64,
}

impl Encoded<'_> {
    fn write_to(&self, w: &mut impl Write) -> io::Result<()> {
        w.write_all(&self.head)?;
        let mut pos = self.head.len() as u64;
        let zeros = [0u8; SECTION_ALIGN as usize];
        for (offset, bytes) in &self.sections {
            w.write_all(&zeros[..(offset - pos) as usize])?;
            w.write_all(bytes)?;
            pos = offset + bytes.len() as u64;
        }
        Ok(())
    }
}

fn align_up(x: u64) -> u64 {
    x.div_ceil(SECTION_ALIGN) * SECTION_ALIGN
}

fn pod_section<T: Pod>(mut items: Vec<T>) -> Vec<u8> {
    disk::swap_words_le(&mut items);
    bytemuck::cast_slice::<T, u8>(&items).to_vec()
}

/// The stored bytes of `r` in `enc`: borrowed when `r` is stored so, else re-encoded.
fn radiance_bytes(r: &Radiance, enc: RadianceEncoding) -> Cow<'_, [u8]> {
    if r.encoding() == enc {
        Cow::Borrowed(r.as_bytes())
    } else {
        Cow::Owned(r.to_encoding(enc).as_bytes().to_vec())
    }
}

fn encode<'a>(
    lf: &'a LightField,
    enc: RadianceEncoding,
    path: &Path,
) -> Result<Encoded<'a>, FormatError> {
    let content = |(element, reason)| FormatError::Content {
        element,
        reason,
        path: path.to_owned(),
    };
    validate_header_content(&lf.params, &lf.to_vlf, &lf.cameras).map_err(content)?;
    let texels = lf.radiance.len() as u64;
    validate_geometry(&lf.triangles, &lf.faces, texels).map_err(content)?;

    let tris: Vec<FileTriangle> = lf.triangles.iter().map(FileTriangle::from).collect();
    let faces: Vec<FileFace> = lf.faces.iter().map(FileFace::from).collect();
    let tri_bytes = pod_section(tris);
    let face_bytes = pod_section(faces);
    // Radiance is finite by construction (`Radiance` cannot hold NaN or infinity).
    let rad_bytes = radiance_bytes(&lf.radiance, enc);

    let tiles = match &lf.tiles {
        Some(t) => {
            let words = tiles::pack(&t.index);
            tiles::validate(&t.index, lf.faces.len(), t.radiance.len())
                .map_err(|r| content(("tile index".into(), r)))?;
            Some((pod_section(words), radiance_bytes(&t.radiance, enc)))
        }
        None => None,
    };
    let entry =
        |name: &str, kind, count: usize, elem: usize, bytes: &[u8], checksum| SectionEntry {
            name: name.into(),
            kind,
            required: true,
            offset: 0,
            byte_len: bytes.len() as u64,
            count: count as u64,
            elem_size: elem as u32,
            checksum,
        };
    let mut sections = vec![
        entry(
            disk::SECTION_TRIANGLES,
            disk::KIND_TRIANGLE,
            lf.triangles.len(),
            size_of::<FileTriangle>(),
            &tri_bytes,
            hash::section_checksum(&tri_bytes),
        ),
        entry(
            disk::SECTION_FACES,
            disk::KIND_FACE,
            lf.faces.len(),
            size_of::<FileFace>(),
            &face_bytes,
            hash::section_checksum(&face_bytes),
        ),
        entry(
            disk::SECTION_RADIANCE,
            disk::KIND_RADIANCE,
            lf.radiance.len(),
            enc.bytes_per_texel(),
            &rad_bytes,
            parallel::section_checksum(&rad_bytes),
        ),
    ];
    let mut bodies = vec![Cow::Owned(tri_bytes), Cow::Owned(face_bytes), rad_bytes];
    if let Some((idx_bytes, vals)) = tiles {
        sections.push(entry(
            disk::SECTION_TILE_INDEX,
            disk::KIND_TILE_INDEX,
            idx_bytes.len() / 4,
            4,
            &idx_bytes,
            hash::section_checksum(&idx_bytes),
        ));
        sections.push(entry(
            disk::SECTION_TILE_RADIANCE,
            disk::KIND_RADIANCE,
            vals.len() / enc.bytes_per_texel(),
            enc.bytes_per_texel(),
            &vals,
            parallel::section_checksum(&vals),
        ));
        bodies.push(Cow::Owned(idx_bytes));
        bodies.push(vals);
    }
    let mut header = FileHeader {
        params: FileParams::from(&lf.params),
        directions: FileDirections::from(&lf.directions),
        transform: FileTransform::from(&lf.to_vlf),
        scene: FileSceneSummary::from(&lf.scene),
        cameras: lf.cameras.iter().map(FileCamera::from).collect(),
        stats: FileStats::from(&lf.stats),
        radiance_encoding: enc.id(),
        texels,
        sections,
    };
    // Offsets are varints in the header, so the header length depends on them: iterate until
    // the aligned header end is stable (it only grows, so this converges in a few rounds).
    let herr = |e: bincode::error::EncodeError| FormatError::Write {
        step: "encoding the header".into(),
        path: path.to_owned(),
        source: io::Error::other(e.to_string()),
    };
    let mut header_bytes = disk::encode_header(&header).map_err(herr)?;
    let mut start = 0;
    let file_len = loop {
        let new_start = align_up((PREAMBLE_LEN + header_bytes.len()) as u64);
        if new_start <= start {
            break header
                .sections
                .last()
                .map_or(start, |s| s.offset + s.byte_len);
        }
        start = new_start;
        let mut pos = start;
        for s in &mut header.sections {
            s.offset = pos;
            pos = align_up(pos + s.byte_len);
        }
        header_bytes = disk::encode_header(&header).map_err(herr)?;
    };
    if header_bytes.len() > MAX_HEADER_LEN {
        return Err(content((
            "header".into(),
            format!(
                "{} bytes exceed the format's limit of {MAX_HEADER_LEN} (too many cameras or bake phases?)",
                header_bytes.len()
            ),
        )));
    }
    let mut preamble = Preamble {
        magic: MAGIC,
        version: VERSION,
        header_len: header_bytes.len() as u32,
        file_len,
        header_checksum: 0,
    };
    preamble.header_checksum = disk::header_checksum(&preamble, &header_bytes);
    let mut head = preamble.to_bytes().to_vec();
    head.extend_from_slice(&header_bytes);
    let offsets: Vec<u64> = header.sections.iter().map(|s| s.offset).collect();
    Ok(Encoded {
        head,
        sections: offsets.into_iter().zip(bodies).collect(),
        len: file_len,
    })
}

// ----- reading ------------------------------------------------------------------------------

/// Preamble and header, checked against each other and the file size.
struct Head {
    preamble: Preamble,
    header: FileHeader,
    encoding: RadianceEncoding,
}

fn escape_bytes(b: &[u8]) -> String {
    let s: String = b
        .iter()
        .flat_map(|&c| std::ascii::escape_default(c))
        .map(char::from)
        .collect();
    format!("\"{s}\"")
}

fn read_head(src: &dyn Source, path: &Path) -> Result<Head, FormatError> {
    let p = || path.to_owned();
    let rerr = |source| FormatError::Read { path: p(), source };
    let len = src.len();
    let mut first = [0u8; PREAMBLE_LEN];
    let avail = len.min(PREAMBLE_LEN as u64) as usize;
    src.read_at(0, &mut first[..avail]).map_err(rerr)?;
    let magic_len = avail.min(MAGIC.len());
    if len == 0 {
        return Err(FormatError::NotVlf {
            found: "nothing (the file is empty)".into(),
            path: p(),
        });
    }
    if first[..magic_len] != MAGIC[..magic_len] {
        return Err(FormatError::NotVlf {
            found: escape_bytes(&first[..magic_len]),
            path: p(),
        });
    }
    if avail < PREAMBLE_LEN {
        return Err(FormatError::Truncated {
            expected: PREAMBLE_LEN as u64,
            found: len,
            path: p(),
        });
    }
    let preamble = Preamble::from_bytes(&first);
    if !disk::SUPPORTED_VERSIONS.contains(&preamble.version) {
        let (lo, hi) = (
            *disk::SUPPORTED_VERSIONS.start(),
            *disk::SUPPORTED_VERSIONS.end(),
        );
        let supported = if lo == hi {
            format!("version {lo} only")
        } else {
            format!("versions {lo} to {hi}")
        };
        let supported = if preamble.version > hi {
            format!("{supported}; the file was written by a newer vlf")
        } else {
            supported
        };
        return Err(FormatError::UnsupportedVersion {
            found: preamble.version,
            supported,
            path: p(),
        });
    }
    let header_len = preamble.header_len as usize;
    if header_len > MAX_HEADER_LEN {
        return Err(FormatError::HeaderTooLarge {
            len: header_len as u64,
            limit: MAX_HEADER_LEN,
            path: p(),
        });
    }
    let header_end = (PREAMBLE_LEN + header_len) as u64;
    if len < header_end {
        return Err(FormatError::Truncated {
            expected: header_end.max(preamble.file_len),
            found: len,
            path: p(),
        });
    }
    let mut header_bytes = vec![0u8; header_len];
    src.read_at(PREAMBLE_LEN as u64, &mut header_bytes)
        .map_err(rerr)?;
    let computed = disk::header_checksum(&preamble, &header_bytes);
    if computed != preamble.header_checksum {
        return Err(FormatError::Checksum {
            section: "header".into(),
            stored: preamble.header_checksum,
            computed,
            path: p(),
        });
    }
    if len < preamble.file_len {
        return Err(FormatError::Truncated {
            expected: preamble.file_len,
            found: len,
            path: p(),
        });
    }
    if len > preamble.file_len {
        return Err(FormatError::TrailingData {
            expected: preamble.file_len,
            found: len,
            path: p(),
        });
    }
    let header = disk::decode_header(&header_bytes)
        .map_err(|reason| FormatError::Header { reason, path: p() })?;
    let encoding = RadianceEncoding::from_id(header.radiance_encoding).ok_or_else(|| {
        let known: Vec<String> = RadianceEncoding::ALL
            .iter()
            .map(|e| format!("{} ({})", e.id(), e.name()))
            .collect();
        FormatError::Header {
            reason: format!(
                "unknown radiance encoding {} (this build reads {})",
                header.radiance_encoding,
                known.join(", ")
            ),
            path: p(),
        }
    })?;
    check_sections(&header, encoding, header_end, preamble.file_len, path)?;
    Ok(Head {
        preamble,
        header,
        encoding,
    })
}

/// The element kind and size a known section must have.
fn known_section(name: &str, enc: RadianceEncoding) -> Option<(u32, usize)> {
    match name {
        disk::SECTION_TRIANGLES => Some((disk::KIND_TRIANGLE, size_of::<FileTriangle>())),
        disk::SECTION_FACES => Some((disk::KIND_FACE, size_of::<FileFace>())),
        disk::SECTION_RADIANCE | disk::SECTION_TILE_RADIANCE => {
            Some((disk::KIND_RADIANCE, enc.bytes_per_texel()))
        }
        disk::SECTION_TILE_INDEX => Some((disk::KIND_TILE_INDEX, 4)),
        _ => None,
    }
}

fn check_sections(
    h: &FileHeader,
    enc: RadianceEncoding,
    header_end: u64,
    file_len: u64,
    path: &Path,
) -> Result<(), FormatError> {
    let serr = |s: &SectionEntry, reason: String| FormatError::Section {
        section: s.name.clone(),
        reason,
        path: path.to_owned(),
    };
    for (i, s) in h.sections.iter().enumerate() {
        if h.sections[..i].iter().any(|o| o.name == s.name) {
            return Err(serr(s, "appears twice in the section table".into()));
        }
        match known_section(&s.name, enc) {
            Some((kind, size)) => {
                if s.kind != kind || s.elem_size as usize != size {
                    return Err(serr(
                        s,
                        format!(
                            "kind {} with {}-byte elements, expected kind {kind} with {size}-byte elements",
                            s.kind, s.elem_size
                        ),
                    ));
                }
            }
            None if s.required => {
                return Err(serr(
                    s,
                    format!(
                        "required section of kind {} unknown to this build (written by a newer vlf?)",
                        s.kind
                    ),
                ));
            }
            None => log::debug!("skipping unknown optional section {:?}", s.name),
        }
        let expected = s.count.checked_mul(u64::from(s.elem_size));
        if expected != Some(s.byte_len) {
            return Err(serr(
                s,
                format!(
                    "{} elements × {} bytes ≠ its byte length {}",
                    s.count, s.elem_size, s.byte_len
                ),
            ));
        }
        if s.offset % SECTION_ALIGN != 0 {
            return Err(serr(
                s,
                format!("offset {} is not a multiple of {SECTION_ALIGN}", s.offset),
            ));
        }
        if s.offset < header_end {
            return Err(serr(
                s,
                format!(
                    "offset {} lies inside the header (which ends at {header_end})",
                    s.offset
                ),
            ));
        }
        match s.offset.checked_add(s.byte_len) {
            Some(end) if end <= file_len => {}
            _ => {
                return Err(serr(
                    s,
                    format!(
                        "bytes {}..{} lie beyond the end of the file ({file_len} bytes)",
                        s.offset,
                        s.offset as u128 + s.byte_len as u128
                    ),
                ));
            }
        }
    }
    let mut by_offset: Vec<&SectionEntry> = h.sections.iter().filter(|s| s.byte_len > 0).collect();
    by_offset.sort_by_key(|s| s.offset);
    for w in by_offset.windows(2) {
        if w[0].offset + w[0].byte_len > w[1].offset {
            return Err(serr(
                w[1],
                format!(
                    "bytes {}..{} overlap section {} (bytes {}..{})",
                    w[1].offset,
                    w[1].offset + w[1].byte_len,
                    w[0].name,
                    w[0].offset,
                    w[0].offset + w[0].byte_len
                ),
            ));
        }
    }
    for name in [
        disk::SECTION_TRIANGLES,
        disk::SECTION_FACES,
        disk::SECTION_RADIANCE,
    ] {
        if !h.sections.iter().any(|s| s.name == name) {
            return Err(FormatError::Section {
                section: name.into(),
                reason: "missing from the section table".into(),
                path: path.to_owned(),
            });
        }
    }
    let has = |name| h.sections.iter().any(|s| s.name == name);
    if has(disk::SECTION_TILE_INDEX) != has(disk::SECTION_TILE_RADIANCE) {
        return Err(FormatError::Section {
            section: disk::SECTION_TILE_INDEX.into(),
            reason: "tile_index and tile_radiance must both be present or both absent".into(),
            path: path.to_owned(),
        });
    }
    if let Some(r) = h.sections.iter().find(|s| s.name == disk::SECTION_RADIANCE)
        && r.count != h.texels
    {
        return Err(serr(
            r,
            format!("{} texels, but the header says {}", r.count, h.texels),
        ));
    }
    Ok(())
}

fn section<'h>(h: &'h FileHeader, name: &str) -> &'h SectionEntry {
    // check_sections guarantees presence; fall back to an empty entry rather than panic.
    static EMPTY: SectionEntry = SectionEntry {
        name: String::new(),
        kind: 0,
        required: false,
        offset: 0,
        byte_len: 0,
        count: 0,
        elem_size: 0,
        checksum: 0,
    };
    h.sections.iter().find(|s| s.name == name).unwrap_or(&EMPTY)
}

fn read_from(src: &dyn Source, path: &Path) -> Result<LightField, FormatError> {
    let head = read_head(src, path)?;
    let h = &head.header;
    let content = |(element, reason)| FormatError::Content {
        element,
        reason,
        path: path.to_owned(),
    };

    let triangles: Vec<FileTriangle> = read_pod(src, section(h, disk::SECTION_TRIANGLES), path)?;
    let faces: Vec<FileFace> = read_pod(src, section(h, disk::SECTION_FACES), path)?;
    let radiance = read_radiance(src, section(h, disk::SECTION_RADIANCE), head.encoding, path)?;

    let desc = h.directions.desc().ok_or_else(|| {
        content((
            "direction set".into(),
            format!("unknown construction scheme {}", h.directions.scheme),
        ))
    })?;
    let directions = DirectionSet::from_desc(&desc)
        .map_err(|e| content(("direction set".into(), e.to_string())))?;
    if directions.len() as u64 != u64::from(h.directions.count) {
        return Err(content((
            "direction set".into(),
            format!(
                "frequency {} gives {} directions, but the header says {}",
                desc.frequency,
                directions.len(),
                h.directions.count
            ),
        )));
    }
    let params = BakeParams::from(&h.params);
    let to_vlf = (&h.transform).into();
    let cameras: Vec<_> = h.cameras.iter().map(Into::into).collect();
    validate_header_content(&params, &to_vlf, &cameras).map_err(content)?;
    let triangles: Vec<BakeTriangle> = triangles.iter().map(Into::into).collect();
    let faces: Vec<BakeFace> = faces.iter().map(Into::into).collect();
    validate_geometry(&triangles, &faces, radiance.len() as u64).map_err(content)?;
    let tiles = match h
        .sections
        .iter()
        .find(|s| s.name == disk::SECTION_TILE_INDEX)
    {
        Some(ix) => {
            let words: Vec<u32> = read_pod(src, ix, path)?;
            let values = read_radiance(
                src,
                section(h, disk::SECTION_TILE_RADIANCE),
                head.encoding,
                path,
            )?;
            let index = tiles::unpack(&words).map_err(|r| content(("tile index".into(), r)))?;
            tiles::validate(&index, faces.len(), values.len())
                .map_err(|r| content(("tile index".into(), r)))?;
            if index.n != params.resolution
                || index.m != params.tile
                || index.directions as usize != directions.len()
            {
                return Err(content((
                    "tile index".into(),
                    format!(
                        "grid {}/{} with {} directions does not match the parameters ({}/{}, {} directions)",
                        index.n,
                        index.m,
                        index.directions,
                        params.resolution,
                        params.tile,
                        directions.len()
                    ),
                )));
            }
            Some(MirrorTiles {
                index,
                radiance: values,
            })
        }
        None => None,
    };

    Ok(LightField {
        params,
        directions,
        to_vlf,
        scene: h.scene.to_summary(),
        cameras,
        triangles,
        faces,
        radiance,
        tiles,
        stats: (&h.stats).into(),
    })
}

/// The element count of a checked section as a `usize`.
fn elements(s: &SectionEntry, path: &Path) -> Result<usize, FormatError> {
    usize::try_from(s.count).map_err(|_| FormatError::Section {
        section: s.name.clone(),
        reason: format!("{} elements do not fit in this platform's memory", s.count),
        path: path.to_owned(),
    })
}

/// Reads a section of `Pod` elements with one read into an aligned `Vec` and checks it.
fn read_pod<T: Pod>(
    src: &dyn Source,
    s: &SectionEntry,
    path: &Path,
) -> Result<Vec<T>, FormatError> {
    // check_sections: count × size_of::<T>() = byte_len ≤ the real file size.
    let mut items = vec![T::zeroed(); elements(s, path)?];
    let bytes = bytemuck::cast_slice_mut::<T, u8>(&mut items);
    src.read_at(s.offset, bytes)
        .map_err(|source| FormatError::Read {
            path: path.to_owned(),
            source,
        })?;
    let computed = hash::section_checksum(bytes);
    if computed != s.checksum {
        return Err(FormatError::Checksum {
            section: s.name.clone(),
            stored: s.checksum,
            computed,
            path: path.to_owned(),
        });
    }
    disk::swap_words_le(&mut items);
    Ok(items)
}

/// Reads the radiance section `s` into memory as stored: one aligned buffer, filled with
/// positioned reads of whole checksum blocks (each thread takes a contiguous run of blocks and
/// reads straight into its part of the buffer), every block hashed and checked for values no
/// writer produces while it is in cache. Nothing is decoded.
fn read_radiance(
    src: &dyn Source,
    s: &SectionEntry,
    enc: RadianceEncoding,
    path: &Path,
) -> Result<Radiance, FormatError> {
    let bpt = enc.bytes_per_texel();
    // check_sections: count × bpt = byte_len ≤ the real file size.
    let len = elements(s, path)?;
    let byte_len = len * bpt;
    let mut words = vec![0u32; enc.words_for(len)];
    let results = parallel::blocks_mut(&mut words, hash::BLOCK / 4, byte_len, |first, w| {
        let mut hashes = Vec::new();
        let mut bad = None;
        for (j, w) in w.chunks_mut(hash::BLOCK / 4).enumerate() {
            let block = first + j;
            let start = block * hash::BLOCK;
            let n = (byte_len - start).min(hash::BLOCK);
            let bytes = &mut bytemuck::cast_slice_mut::<u32, u8>(w)[..n];
            src.read_at(s.offset + start as u64, bytes)?;
            hashes.push(hash::block_hash(bytes, block));
            if let Err(i) = enc.check_stored(w, n / bpt) {
                bad = bad.or(Some(start / bpt + i));
            }
        }
        Ok::<_, io::Error>((hashes, bad))
    });
    let mut hashes = Vec::new();
    let mut bad = None;
    for r in results {
        let (h, b) = r.map_err(|source| FormatError::Read {
            path: path.to_owned(),
            source,
        })?;
        hashes.extend(h);
        bad = bad.or(b);
    }
    let computed = hash::combine(&hashes, s.byte_len);
    if computed != s.checksum {
        return Err(FormatError::Checksum {
            section: s.name.clone(),
            stored: s.checksum,
            computed,
            path: path.to_owned(),
        });
    }
    if let Some(i) = bad {
        let element = if s.name == disk::SECTION_RADIANCE {
            format!("radiance texel {i}")
        } else {
            format!("{} value {i}", s.name)
        };
        return Err(FormatError::Content {
            element,
            reason: format!(
                "not a stored {} value (negative, infinite or NaN)",
                enc.name()
            ),
            path: path.to_owned(),
        });
    }
    Ok(Radiance::from_checked_words(enc, len, words))
}

// ----- validation (shared by writer and reader) ---------------------------------------------

type Invalid = (String, String);

fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn validate_header_content(
    params: &BakeParams,
    to_vlf: &crate::scene::Similarity,
    cameras: &[crate::scene::Camera],
) -> Result<(), Invalid> {
    params
        .validate()
        .map_err(|e| ("parameters".to_string(), e.to_string()))?;
    if !(to_vlf.center.is_finite() && to_vlf.scale.is_finite() && to_vlf.scale > 0.0) {
        return Err((
            "transform".into(),
            format!(
                "centre {:?} and scale {} must be finite with a positive scale",
                to_vlf.center, to_vlf.scale
            ),
        ));
    }
    for (i, c) in cameras.iter().enumerate() {
        let ok = c.position.is_finite()
            && c.rotation.is_finite()
            && c.yfov.is_finite()
            && c.znear.is_finite()
            && c.aspect_ratio.is_none_or(f32::is_finite)
            && c.zfar.is_none_or(|z| !z.is_nan());
        if !ok {
            return Err((format!("camera {i}"), "non-finite value".into()));
        }
    }
    Ok(())
}

fn validate_geometry(
    triangles: &[BakeTriangle],
    faces: &[BakeFace],
    texels: u64,
) -> Result<(), Invalid> {
    for (i, f) in faces.iter().enumerate() {
        let el = || format!("face {i}");
        let floats = [
            &f.normal[..],
            &f.origin,
            &f.u,
            &f.v,
            &[f.offset, f.texel_size, f.specular],
        ];
        if !floats.iter().all(|v| finite(v)) {
            return Err((el(), "non-finite value".into()));
        }
        if f.width == 0 || f.height == 0 {
            return Err((
                el(),
                format!("empty chart ({} × {} texels)", f.width, f.height),
            ));
        }
        if f.texel_size <= 0.0 {
            return Err((el(), format!("texel size {} is not positive", f.texel_size)));
        }
        if f.kind > FACE_MIXED {
            return Err((el(), format!("unknown face kind {}", f.kind)));
        }
        let end = u128::from(f.texel_base) + 2 * u128::from(f.width) * u128::from(f.height);
        if end > u128::from(texels) {
            return Err((
                el(),
                format!(
                    "texels {}..{end} lie beyond the radiance array ({texels} texels)",
                    f.texel_base
                ),
            ));
        }
    }
    for (i, t) in triangles.iter().enumerate() {
        if t.face as usize >= faces.len() {
            return Err((
                format!("triangle {i}"),
                format!(
                    "face index {} is out of range ({} faces)",
                    t.face,
                    faces.len()
                ),
            ));
        }
        if !(finite(&t.p0) && finite(&t.p1) && finite(&t.p2)) {
            return Err((
                format!("triangle {i}"),
                "non-finite vertex coordinate".into(),
            ));
        }
    }
    Ok(())
}
