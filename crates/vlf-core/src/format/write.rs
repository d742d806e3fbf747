//! Encoding a light field into the bytes of a file: sections, checksums, header and preamble.

use std::borrow::Cow;
use std::io::{self, Write};
use std::path::Path;

use bytemuck::Pod;

use super::FormatError;
use super::disk::{
    self, FileCamera, FileDirections, FileFace, FileGatherSampling, FileHeader, FileParams,
    FileSceneSummary, FileStats, FileTransform, FileTriangle, MAGIC, MAX_HEADER_LEN, PREAMBLE_LEN,
    Preamble, SECTION_ALIGN, SectionEntry, VERSION,
};
use super::validate::{validate_geometry, validate_header_content, validate_shading};
use super::{shading, tiles};
use crate::lightfield::{LightField, Radiance, RadianceEncoding};
use crate::parallel;

/// An encoded file, ready to be written: radiance stored in the requested encoding is
/// borrowed from the light field, not copied.
pub(super) struct Encoded<'a> {
    head: Vec<u8>,
    /// (offset, bytes) in file order.
    sections: Vec<(u64, Cow<'a, [u8]>)>,
    pub(super) len: u64,
}

impl Encoded<'_> {
    pub(super) fn write_to(&self, w: &mut impl Write) -> io::Result<()> {
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

/// The sections of a file being encoded: their header entries and bodies, in file order.
#[derive(Default)]
struct Sections<'a> {
    entries: Vec<SectionEntry>,
    bodies: Vec<Cow<'a, [u8]>>,
}

impl<'a> Sections<'a> {
    /// Adds section `name` (required) of `count` elements of `elem` bytes each.
    fn add(
        &mut self,
        name: &str,
        kind: u32,
        count: usize,
        elem: usize,
        body: Cow<'a, [u8]>,
    ) -> &mut SectionEntry {
        self.entries.push(SectionEntry {
            name: name.into(),
            kind,
            required: true,
            offset: 0,
            byte_len: body.len() as u64,
            count: count as u64,
            elem_size: elem as u32,
            checksum: parallel::section_checksum(&body),
        });
        self.bodies.push(body);
        self.entries.last_mut().expect("just pushed")
    }

    /// Adds section `name` (required) holding `items` as stored records.
    fn add_pod<T: Pod>(&mut self, name: &str, kind: u32, items: Vec<T>) -> &mut SectionEntry {
        let count = items.len();
        self.add(
            name,
            kind,
            count,
            size_of::<T>(),
            Cow::Owned(pod_section(items)),
        )
    }
}

/// Every section of `lf` with radiance in `enc`: geometry, shading, irradiance, then the
/// optional ones the light field has (mirror tiles, masks and panes, per-corner attributes, the
/// gather's sampling record). Errors as (element, reason).
fn sections(lf: &LightField, enc: RadianceEncoding) -> Result<Sections<'_>, (String, String)> {
    let mut s = Sections::default();
    let tris: Vec<FileTriangle> = lf.triangles.iter().map(FileTriangle::from).collect();
    let faces: Vec<FileFace> = lf.faces.iter().map(FileFace::from).collect();
    s.add_pod(disk::SECTION_TRIANGLES, disk::KIND_TRIANGLE, tris);
    s.add_pod(disk::SECTION_FACES, disk::KIND_FACE, faces);
    let (materials, uvs, textures) = shading::pack(&lf.shading);
    s.add_pod(disk::SECTION_MATERIALS, disk::KIND_MATERIAL, materials);
    s.add_pod(disk::SECTION_UVS, disk::KIND_UVS, uvs);
    s.add_pod(disk::SECTION_TEXTURES, disk::KIND_TEXTURE, textures);
    // Always f16 (checked by validate_shading): borrowed as stored.
    s.add(
        disk::SECTION_TEXELS,
        disk::KIND_TEXELS,
        lf.shading.texels.len(),
        disk::TEXEL_BYTES,
        Cow::Borrowed(lf.shading.texels.as_bytes()),
    );
    // Light values are finite by construction (`Radiance` cannot hold NaN or infinity).
    s.add(
        disk::SECTION_IRRADIANCE,
        disk::KIND_RADIANCE,
        lf.irradiance.len(),
        enc.bytes_per_texel(),
        radiance_bytes(&lf.irradiance, enc),
    );
    if let Some(t) = &lf.tiles {
        let words = tiles::pack(&t.index);
        tiles::validate(&t.index, lf.faces.len(), t.radiance.len())
            .map_err(|r| ("tile index".to_string(), r))?;
        s.add_pod(disk::SECTION_TILE_INDEX, disk::KIND_TILE_INDEX, words);
        let vals = radiance_bytes(&t.radiance, enc);
        let count = vals.len() / enc.bytes_per_texel();
        s.add(
            disk::SECTION_TILE_RADIANCE,
            disk::KIND_RADIANCE,
            count,
            enc.bytes_per_texel(),
            vals,
        );
    }
    if shading::has_surfaces(&lf.shading) {
        let recs: Vec<shading::FileSurface> = (lf.shading.materials.iter())
            .map(shading::FileSurface::from)
            .collect();
        s.add_pod(disk::SECTION_SURFACES, disk::KIND_SURFACE, recs);
    }
    if !lf.shading.alpha.is_empty() {
        let bytes: Vec<u8> = lf
            .shading
            .alpha
            .iter()
            .flat_map(|a| a.to_le_bytes())
            .collect();
        let n = lf.shading.alpha.len();
        s.add(
            disk::SECTION_TEXTURE_ALPHA,
            disk::KIND_TEXTURE_ALPHA,
            n,
            2,
            Cow::Owned(bytes),
        );
    }
    // The per-corner attributes, where the scene has them (required: a reader that does not
    // know them cannot render the file right).
    let attrs = shading::pack_attributes(&lf.shading);
    if let Some(uvs1) = attrs.uvs1 {
        s.add_pod(disk::SECTION_UVS1, disk::KIND_UVS1, uvs1);
    }
    if let Some(normals) = attrs.normals {
        s.add_pod(disk::SECTION_NORMALS, disk::KIND_CORNERS, normals);
    }
    if let Some(colors) = attrs.colors {
        s.add_pod(disk::SECTION_COLORS, disk::KIND_CORNERS, colors);
    }
    if let Some(texcoords) = attrs.texcoords {
        s.add_pod(
            disk::SECTION_MATERIAL_TEXCOORDS,
            disk::KIND_MATERIAL_TEXCOORDS,
            texcoords,
        );
    }
    if let Some(rec) = (lf.params.final_gather.as_ref()).and_then(FileGatherSampling::of) {
        s.add_pod(
            disk::SECTION_GATHER_SAMPLING,
            disk::KIND_GATHER_SAMPLING,
            vec![rec],
        )
        .required = false;
    }
    Ok(s)
}

pub(super) fn encode<'a>(
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
    let texels = lf.irradiance.len() as u64;
    validate_geometry(&lf.triangles, &lf.faces, texels, lf.shading.materials.len())
        .map_err(content)?;
    validate_shading(&lf.shading, lf.triangles.len()).map_err(content)?;

    let sections = sections(lf, enc).map_err(content)?;
    let Sections {
        entries: sections,
        bodies,
    } = sections;
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
