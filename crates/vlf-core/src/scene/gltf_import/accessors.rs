//! Buffers, buffer views and accessors: external and embedded bytes, and accessors read into
//! `f64` components with every index and byte range checked.

use std::path::Path;

use gltf::json::{self, validation::Checked};

use super::{Importer, element, short};
use crate::scene::SceneError;
use crate::scene::uri::{self, UriTarget};

/// Sparse accessors without a bufferView allocate `count` zeroed elements; cap the
/// number of components they may allocate.
const MAX_SPARSE_ONLY_VALUES: u64 = 1 << 24;
/// An accessor read into `f64` components (exact for every glTF component type).
pub(super) struct AccessorData {
    pub(super) values: Vec<f64>,
    pub(super) comps: usize,
    pub(super) component: json::accessor::ComponentType,
    normalized: bool,
}

impl AccessorData {
    /// Whether integer components are normalised (`accessor.normalized`).
    pub(super) fn normalized(&self) -> bool {
        self.normalized
    }

    pub(super) fn count(&self) -> usize {
        self.values.len() / self.comps.max(1)
    }

    /// Value `c` of element `e`, normalised to `[0, 1]` / `[−1, 1]` when the accessor says so.
    pub(super) fn attribute(&self, e: usize, c: usize) -> f64 {
        use json::accessor::ComponentType as C;
        let v = self.values[e * self.comps + c];
        if !self.normalized {
            return v;
        }
        match self.component {
            C::I8 => (v / 127.0).max(-1.0),
            C::U8 => v / 255.0,
            C::I16 => (v / 32767.0).max(-1.0),
            C::U16 => v / 65535.0,
            C::U32 => v / 4_294_967_295.0,
            C::F32 => v,
        }
    }
}

fn component_size(c: json::accessor::ComponentType) -> usize {
    use json::accessor::ComponentType as C;
    match c {
        C::I8 | C::U8 => 1,
        C::I16 | C::U16 => 2,
        C::U32 | C::F32 => 4,
    }
}

/// Reads one component; `None` when `bytes` is too short (never after validation).
fn read_component(bytes: &[u8], offset: usize, c: json::accessor::ComponentType) -> Option<f64> {
    use json::accessor::ComponentType as C;
    let b = bytes.get(offset..offset.checked_add(component_size(c))?)?;
    Some(match c {
        C::I8 => f64::from(b[0] as i8),
        C::U8 => f64::from(b[0]),
        C::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
        C::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
        C::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        C::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
    })
}

impl Importer<'_> {
    /// Reads a whole external file, with a reason string on failure.
    fn read_file(file: &Path) -> Result<Vec<u8>, String> {
        match std::fs::metadata(file) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err("file not found".to_string());
            }
            Err(e) => return Err(e.to_string()),
            Ok(m) if !m.is_file() => return Err("not a regular file".to_string()),
            Ok(_) => {}
        }
        std::fs::read(file).map_err(|e| e.to_string())
    }

    /// Bytes of a `uri` (data URI or file) and the file name for messages; on failure
    /// the file name and the reason.
    pub(super) fn read_uri(&self, uri: &str) -> Result<(Vec<u8>, String), (String, String)> {
        match uri::resolve(uri, &self.base_dir) {
            Ok(UriTarget::Data(_media, bytes)) => Ok((bytes, "embedded data URI".to_string())),
            Ok(UriTarget::File(file)) => {
                let name = file.display().to_string();
                match Self::read_file(&file) {
                    Ok(bytes) => Ok((bytes, name)),
                    Err(reason) => Err((name, reason)),
                }
            }
            Err(reason) => {
                let shown = if uri.starts_with("data:") {
                    "embedded data URI".to_string()
                } else {
                    short(uri)
                };
                Err((shown, reason))
            }
        }
    }

    pub(super) fn load_buffers(&mut self, bin: Option<&[u8]>) -> Result<(), SceneError> {
        let mut bin = bin;
        let mut buffers = Vec::with_capacity(self.root.buffers.len().min(1024));
        for (i, b) in self.root.buffers.iter().enumerate() {
            let el = element("buffer", i, b.name.as_ref());
            let (mut data, file) = match &b.uri {
                None => match bin.take() {
                    Some(chunk) if i == 0 => (chunk.to_vec(), "the GLB binary chunk".to_string()),
                    _ => {
                        return Err(self.resource(
                            el,
                            "the GLB binary chunk".to_string(),
                            "the buffer has no uri and there is no GLB binary chunk for it"
                                .to_string(),
                        ));
                    }
                },
                Some(uri) => match self.read_uri(uri) {
                    Ok((bytes, file)) => (bytes, file),
                    Err((file, reason)) => return Err(self.resource(el, file, reason)),
                },
            };
            let need = b.byte_length.0;
            if (data.len() as u64) < need {
                return Err(self.invalid(
                    el,
                    format!(
                        "byteLength is {need} but {file} holds only {} bytes",
                        data.len()
                    ),
                ));
            }
            data.truncate(need as usize);
            buffers.push(data);
        }
        self.buffers = buffers;
        Ok(())
    }

    /// The bytes of `count` elements of `elem` bytes at `offset` in buffer view `view`.
    /// Returns the slice (starting at the first element) and the stride.
    pub(super) fn view_slice(
        &self,
        el: &str,
        view: usize,
        offset: u64,
        elem: usize,
        count: u64,
        packed: bool,
    ) -> Result<(&[u8], usize), SceneError> {
        let v = self.root.buffer_views.get(view).ok_or_else(|| {
            self.invalid(
                el,
                format!(
                    "bufferView {view} is out of range ({} buffer views)",
                    self.root.buffer_views.len()
                ),
            )
        })?;
        let b = v.buffer.value();
        let data = self.buffers.get(b).ok_or_else(|| {
            self.invalid(
                format!("bufferView {view}"),
                format!(
                    "buffer {b} is out of range ({} buffers)",
                    self.buffers.len()
                ),
            )
        })?;
        let start = v.byte_offset.map_or(0, |o| o.0);
        let len = v.byte_length.0;
        start
            .checked_add(len)
            .filter(|&e| e <= data.len() as u64)
            .ok_or_else(|| {
                self.invalid(
                    format!("bufferView {view}"),
                    format!(
                        "bytes {start}..{} exceed buffer {b} ({} bytes)",
                        start.saturating_add(len),
                        data.len()
                    ),
                )
            })?;
        let stride = match v.byte_stride {
            Some(s) if !packed => {
                if s.0 < elem {
                    return Err(self.invalid(
                        format!("bufferView {view}"),
                        format!("byteStride {} is smaller than the element size {elem}", s.0),
                    ));
                }
                s.0
            }
            _ => elem,
        };
        if count == 0 {
            return Ok((&[], stride));
        }
        let need = (stride as u64)
            .checked_mul(count - 1)
            .and_then(|x| x.checked_add(elem as u64))
            .and_then(|x| x.checked_add(offset));
        match need {
            Some(need) if need <= len => {
                let first = (start + offset) as usize;
                Ok((&data[first..(start + need) as usize], stride))
            }
            _ => Err(self.invalid(
                el,
                format!(
                    "{count} elements of {elem} bytes (stride {stride}) at offset {offset} do not fit bufferView {view} ({len} bytes)",
                ),
            )),
        }
    }

    /// Reads accessor `index` for `user` (e.g. "mesh 0 primitive 1 POSITION").
    pub(super) fn read_accessor(
        &self,
        user: &str,
        index: usize,
    ) -> Result<AccessorData, SceneError> {
        use json::accessor::{ComponentType, Type};
        let acc = self.root.accessors.get(index).ok_or_else(|| {
            self.invalid(
                user,
                format!(
                    "accessor index {index} is out of range ({} accessors)",
                    self.root.accessors.len()
                ),
            )
        })?;
        let el = format!("{user}: accessor {index}");
        let component = match acc.component_type {
            Checked::Valid(json::accessor::GenericComponentType(c)) => c,
            Checked::Invalid => return Err(self.invalid(el, "invalid componentType")),
        };
        let comps = match acc.type_ {
            Checked::Valid(Type::Scalar) => 1,
            Checked::Valid(Type::Vec2) => 2,
            Checked::Valid(Type::Vec3) => 3,
            Checked::Valid(Type::Vec4 | Type::Mat2) => 4,
            Checked::Valid(Type::Mat3) => 9,
            Checked::Valid(Type::Mat4) => 16,
            Checked::Invalid => return Err(self.invalid(el, "invalid type")),
        };
        let csize = component_size(component);
        let elem = csize * comps;
        let count = acc.count.0;
        let mut values: Vec<f64> = match acc.buffer_view {
            Some(view) => {
                let offset = acc.byte_offset.map_or(0, |o| o.0);
                let (bytes, stride) =
                    self.view_slice(&el, view.value(), offset, elem, count, false)?;
                let mut values = Vec::with_capacity(count as usize * comps);
                for e in 0..count as usize {
                    for c in 0..comps {
                        let v = read_component(bytes, e * stride + c * csize, component)
                            .ok_or_else(|| self.invalid(&el, "read past the end of its data"))?;
                        values.push(v);
                    }
                }
                values
            }
            None => {
                if acc.sparse.is_none() {
                    return Err(self.invalid(el, "has neither a bufferView nor sparse data"));
                }
                if count.saturating_mul(comps as u64) > MAX_SPARSE_ONLY_VALUES {
                    return Err(self.invalid(
                        el,
                        format!(
                            "sparse accessor without bufferView: count {count} exceeds the limit {}",
                            MAX_SPARSE_ONLY_VALUES / comps as u64
                        ),
                    ));
                }
                vec![0.0; count as usize * comps]
            }
        };
        if let Some(sparse) = &acc.sparse {
            let n = sparse.count.0;
            if n > count {
                return Err(self.invalid(
                    el,
                    format!("sparse count {n} exceeds the accessor count {count}"),
                ));
            }
            let index_type = match sparse.indices.component_type {
                Checked::Valid(json::accessor::IndexComponentType(
                    c @ (ComponentType::U8 | ComponentType::U16 | ComponentType::U32),
                )) => c,
                _ => return Err(self.invalid(el, "invalid sparse indices componentType")),
            };
            let isize_ = component_size(index_type);
            let (ibytes, _) = self.view_slice(
                &format!("{el} sparse indices"),
                sparse.indices.buffer_view.value(),
                sparse.indices.byte_offset.0,
                isize_,
                n,
                true,
            )?;
            let (vbytes, _) = self.view_slice(
                &format!("{el} sparse values"),
                sparse.values.buffer_view.value(),
                sparse.values.byte_offset.0,
                elem,
                n,
                true,
            )?;
            for k in 0..n as usize {
                let target = read_component(ibytes, k * isize_, index_type)
                    .ok_or_else(|| self.invalid(&el, "sparse indices out of range"))?;
                if target >= count as f64 {
                    return Err(self.invalid(
                        el,
                        format!("sparse index {target} is out of range (count {count})"),
                    ));
                }
                let t = target as usize;
                for c in 0..comps {
                    values[t * comps + c] = read_component(vbytes, k * elem + c * csize, component)
                        .ok_or_else(|| self.invalid(&el, "sparse values out of range"))?;
                }
            }
        }
        Ok(AccessorData {
            values,
            comps,
            component,
            normalized: acc.normalized,
        })
    }
}
