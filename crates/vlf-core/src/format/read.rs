//! Reading a file: preamble and header checked against each other and the file size, the
//! section table checked before anything is allocated, every section read, verified and
//! converted.

use std::io;
use std::path::Path;

use bytemuck::Pod;

use super::FormatError;
use super::disk::{
    self, FileFace, FileHeader, FileTriangle, MAGIC, MAX_HEADER_LEN, PREAMBLE_LEN, Preamble,
    SECTION_ALIGN, SectionEntry,
};
use super::shading::{self, FileMaterial, FileTexture, FileUvs};
use super::source::Source;
use super::tiles;
use super::validate::{validate_geometry, validate_header_content, validate_shading};
use crate::directions::DirectionSet;
use crate::hash;
use crate::lightfield::{
    BakeFace, BakeParams, BakeTriangle, LightField, MirrorTiles, Radiance, RadianceEncoding,
};
use crate::parallel;

/// Preamble and header, checked against each other and the file size.
pub(super) struct Head {
    pub(super) preamble: Preamble,
    pub(super) header: FileHeader,
    pub(super) encoding: RadianceEncoding,
}

fn escape_bytes(b: &[u8]) -> String {
    let s: String = b
        .iter()
        .flat_map(|&c| std::ascii::escape_default(c))
        .map(char::from)
        .collect();
    format!("\"{s}\"")
}

pub(super) fn read_head(src: &dyn Source, path: &Path) -> Result<Head, FormatError> {
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
            format!("{supported}; the file was written by an older vlf: bake the scene again")
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
        disk::SECTION_IRRADIANCE | disk::SECTION_TILE_RADIANCE => {
            Some((disk::KIND_RADIANCE, enc.bytes_per_texel()))
        }
        disk::SECTION_TILE_INDEX => Some((disk::KIND_TILE_INDEX, 4)),
        disk::SECTION_MATERIALS => Some((disk::KIND_MATERIAL, size_of::<FileMaterial>())),
        disk::SECTION_UVS => Some((disk::KIND_UVS, size_of::<FileUvs>())),
        disk::SECTION_TEXTURES => Some((disk::KIND_TEXTURE, size_of::<FileTexture>())),
        disk::SECTION_TEXELS => Some((disk::KIND_TEXELS, disk::TEXEL_BYTES)),
        disk::SECTION_SURFACES => {
            Some((disk::KIND_SURFACE, size_of::<super::shading::FileSurface>()))
        }
        disk::SECTION_TEXTURE_ALPHA => Some((disk::KIND_TEXTURE_ALPHA, 2)),
        disk::SECTION_GATHER_SAMPLING => Some((
            disk::KIND_GATHER_SAMPLING,
            size_of::<disk::FileGatherSampling>(),
        )),
        disk::SECTION_UVS1 => Some((disk::KIND_UVS1, size_of::<FileUvs>())),
        disk::SECTION_NORMALS | disk::SECTION_COLORS => {
            Some((disk::KIND_CORNERS, size_of::<shading::FileCorners>()))
        }
        disk::SECTION_MATERIAL_TEXCOORDS => Some((disk::KIND_MATERIAL_TEXCOORDS, 4)),
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
        disk::SECTION_IRRADIANCE,
        disk::SECTION_MATERIALS,
        disk::SECTION_UVS,
        disk::SECTION_TEXTURES,
        disk::SECTION_TEXELS,
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
    if let Some(r) = h
        .sections
        .iter()
        .find(|s| s.name == disk::SECTION_IRRADIANCE)
        && r.count != h.texels
    {
        return Err(serr(
            r,
            format!("{} texels, but the header says {}", r.count, h.texels),
        ));
    }
    let count = |name| h.sections.iter().find(|s| s.name == name).map(|s| s.count);
    let tris = count(disk::SECTION_TRIANGLES);
    for (name, what) in [
        (disk::SECTION_UVS, "uv triples"),
        (disk::SECTION_UVS1, "uv triples"),
        (disk::SECTION_NORMALS, "normal triples"),
        (disk::SECTION_COLORS, "colour triples"),
    ] {
        if let (Some(n), Some(tris)) = (count(name), tris)
            && n != tris
        {
            return Err(FormatError::Section {
                section: name.into(),
                reason: format!("{n} {what} for {tris} triangles"),
                path: path.to_owned(),
            });
        }
    }
    if let (Some(n), Some(m)) = (
        count(disk::SECTION_MATERIAL_TEXCOORDS),
        count(disk::SECTION_MATERIALS),
    ) && n != m
    {
        return Err(FormatError::Section {
            section: disk::SECTION_MATERIAL_TEXCOORDS.into(),
            reason: format!("{n} words for {m} materials"),
            path: path.to_owned(),
        });
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

pub(super) fn read_from(src: &dyn Source, path: &Path) -> Result<LightField, FormatError> {
    let head = read_head(src, path)?;
    let h = &head.header;
    let content = |(element, reason)| FormatError::Content {
        element,
        reason,
        path: path.to_owned(),
    };

    let triangles: Vec<FileTriangle> = read_pod(src, section(h, disk::SECTION_TRIANGLES), path)?;
    let faces: Vec<FileFace> = read_pod(src, section(h, disk::SECTION_FACES), path)?;
    let irradiance = read_radiance(
        src,
        section(h, disk::SECTION_IRRADIANCE),
        head.encoding,
        path,
    )?;
    let materials: Vec<FileMaterial> = read_pod(src, section(h, disk::SECTION_MATERIALS), path)?;
    let uvs: Vec<FileUvs> = read_pod(src, section(h, disk::SECTION_UVS), path)?;
    let textures: Vec<FileTexture> = read_pod(src, section(h, disk::SECTION_TEXTURES), path)?;
    let texels = read_radiance(
        src,
        section(h, disk::SECTION_TEXELS),
        RadianceEncoding::RgbF16,
        path,
    )?;

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
    let params = params_of(src, h, path)?;
    let to_vlf = (&h.transform).into();
    let cameras: Vec<_> = h.cameras.iter().map(Into::into).collect();
    validate_header_content(&params, &to_vlf, &cameras).map_err(content)?;
    let triangles: Vec<BakeTriangle> = triangles.iter().map(Into::into).collect();
    let faces: Vec<BakeFace> = faces.iter().map(Into::into).collect();
    let mut shading = shading::unpack(&materials, &uvs, &textures, texels).map_err(content)?;
    if let Some(sec) = h.sections.iter().find(|s| s.name == disk::SECTION_SURFACES) {
        let recs: Vec<shading::FileSurface> = read_pod(src, sec, path)?;
        if recs.len() != shading.materials.len() {
            return Err(content((
                "surfaces".into(),
                format!(
                    "{} records for {} materials",
                    recs.len(),
                    shading.materials.len()
                ),
            )));
        }
        for (i, (r, m)) in recs.iter().zip(&mut shading.materials).enumerate() {
            r.apply(m)
                .map_err(|reason| content((format!("surface of material {i}"), reason)))?;
        }
    }
    if let Some(sec) = h
        .sections
        .iter()
        .find(|s| s.name == disk::SECTION_TEXTURE_ALPHA)
    {
        shading.alpha = read_u16s(src, sec, path)?;
    }
    let optional = |name: &str| h.sections.iter().find(|s| s.name == name);
    let attrs = shading::Attributes {
        uvs1: optional(disk::SECTION_UVS1)
            .map(|s| read_pod(src, s, path))
            .transpose()?,
        normals: optional(disk::SECTION_NORMALS)
            .map(|s| read_pod(src, s, path))
            .transpose()?,
        colors: optional(disk::SECTION_COLORS)
            .map(|s| read_pod(src, s, path))
            .transpose()?,
        texcoords: optional(disk::SECTION_MATERIAL_TEXCOORDS)
            .map(|s| read_pod(src, s, path))
            .transpose()?,
    };
    shading::unpack_attributes(&mut shading, attrs).map_err(content)?;
    validate_geometry(
        &triangles,
        &faces,
        irradiance.len() as u64,
        shading.materials.len(),
    )
    .map_err(content)?;
    validate_shading(&shading, triangles.len()).map_err(content)?;
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
        irradiance,
        shading,
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

/// The bake parameters a file records: the header's, with the final gather's sampling and
/// denoising from section `gather_sampling` where the file has one. [`read_from`] and
/// [`super::describe`] both read them here, so a file's parameters are the same whichever way
/// it is opened (`vlf-bake batch` compares them to decide whether an output is up to date).
pub(super) fn params_of(
    src: &dyn Source,
    h: &FileHeader,
    path: &Path,
) -> Result<BakeParams, FormatError> {
    let content = |(element, reason)| FormatError::Content {
        element,
        reason,
        path: path.to_owned(),
    };
    let mut params = BakeParams::from(&h.params);
    if let Some(s) = h
        .sections
        .iter()
        .find(|s| s.name == disk::SECTION_GATHER_SAMPLING)
    {
        let rec: Vec<disk::FileGatherSampling> = read_pod(src, s, path)?;
        match (rec.as_slice(), params.final_gather.as_mut()) {
            ([r], Some(g)) => r
                .apply(g)
                .map_err(|reason| content(("gather sampling".into(), reason)))?,
            _ => {
                return Err(content((
                    "gather sampling".into(),
                    format!(
                        "{} records for {} final gather",
                        rec.len(),
                        if params.final_gather.is_some() {
                            "a"
                        } else {
                            "no"
                        }
                    ),
                )));
            }
        }
    }
    Ok(params)
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

/// Reads a section of little-endian `u16`s (texture alpha), checksum verified.
fn read_u16s(src: &dyn Source, s: &SectionEntry, path: &Path) -> Result<Vec<u16>, FormatError> {
    let mut bytes = vec![0u8; elements(s, path)?.saturating_mul(2)];
    src.read_at(s.offset, &mut bytes)
        .map_err(|source| FormatError::Read {
            path: path.to_owned(),
            source,
        })?;
    let computed = hash::section_checksum(&bytes);
    if computed != s.checksum {
        return Err(FormatError::Checksum {
            section: s.name.clone(),
            stored: s.checksum,
            computed,
            path: path.to_owned(),
        });
    }
    Ok(bytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect())
}

/// Reads the light section `s` (irradiance, tile radiance or texture texels) into memory as
/// stored: one aligned buffer, filled with
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
        let element = match s.name.as_str() {
            disk::SECTION_IRRADIANCE => format!("irradiance texel {i}"),
            disk::SECTION_TEXELS => format!("texture texel {i}"),
            _ => format!("{} value {i}", s.name),
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
