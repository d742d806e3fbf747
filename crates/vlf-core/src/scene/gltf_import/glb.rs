//! The GLB container: a binary glTF file's JSON and BIN chunks.

/// Splits a GLB file into its JSON chunk and optional BIN chunk.
pub(super) fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let u32_at = |o: usize| -> Option<u32> {
        bytes
            .get(o..o.checked_add(4)?)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    if bytes.len() < 12 {
        return Err(format!(
            "file has {} bytes, shorter than the 12-byte GLB header",
            bytes.len()
        ));
    }
    let version = u32_at(4).unwrap_or(0);
    if version != 2 {
        return Err(format!("unsupported GLB version {version} (expected 2)"));
    }
    let length = u32_at(8).unwrap_or(0) as usize;
    if length < 12 || length > bytes.len() {
        return Err(format!(
            "header length {length} does not fit the file size {}",
            bytes.len()
        ));
    }
    let mut json = None;
    let mut bin = None;
    let mut offset = 12usize;
    let mut chunk = 0usize;
    while offset < length {
        if length - offset < 8 {
            return Err(format!("truncated chunk header at byte {offset}"));
        }
        let chunk_len = u32_at(offset).unwrap_or(0) as usize;
        let kind = &bytes[offset + 4..offset + 8];
        let start = offset + 8;
        let end = start
            .checked_add(chunk_len)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                format!("chunk {chunk} ({chunk_len} bytes at byte {start}) runs past the end of the file")
            })?;
        let data = &bytes[start..end];
        match (chunk, kind) {
            (0, b"JSON") => json = Some(data),
            (0, _) => return Err("the first chunk is not a JSON chunk".to_string()),
            (1, b"BIN\0") => bin = Some(data),
            _ => {} // unknown chunk types are ignored (glTF spec)
        }
        offset = end;
        chunk += 1;
    }
    let json = json.ok_or("no JSON chunk")?;
    Ok((json, bin))
}
