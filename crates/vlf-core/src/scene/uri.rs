//! URI handling for glTF resources: data URIs (base64), percent-decoding and
//! file resolution. Written here (instead of using the gltf crate's importer) so that
//! every failure becomes an error naming the resource, never a panic.

use std::path::{Path, PathBuf};

/// Where a glTF `uri` points.
#[derive(Debug, PartialEq)]
pub(crate) enum UriTarget {
    /// `data:` URI, already decoded: (media type, bytes).
    Data(String, Vec<u8>),
    /// A file on disk, resolved against the scene file's folder.
    File(PathBuf),
}

/// Resolves a glTF URI. Errors are human-readable reasons (without the element).
pub(crate) fn resolve(uri: &str, base_dir: &Path) -> Result<UriTarget, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some(comma) = rest.find(',') else {
            return Err("malformed data URI (no ',')".to_string());
        };
        let (header, payload) = (&rest[..comma], &rest[comma + 1..]);
        let (media, is_base64) = match header.strip_suffix(";base64") {
            Some(media) => (media, true),
            None => (header, false),
        };
        let bytes = if is_base64 {
            base64_decode(payload).map_err(|e| format!("bad base64 in data URI: {e}"))?
        } else {
            percent_decode(payload)?
        };
        return Ok(UriTarget::Data(media.to_string(), bytes));
    }
    let path_part = if let Some(rest) = uri.strip_prefix("file://") {
        Some(rest)
    } else {
        uri.strip_prefix("file:")
    };
    if let Some(rest) = path_part {
        let decoded = percent_decode_utf8(rest)?;
        return Ok(UriTarget::File(PathBuf::from(decoded)));
    }
    // Any other "scheme:" before the first '/' is a network or unknown scheme.
    if let Some(colon) = uri.find(':') {
        let scheme = &uri[..colon];
        if !scheme.is_empty()
            && !scheme.contains('/')
            && scheme
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
        {
            return Err(format!("unsupported URI scheme '{scheme}:'"));
        }
    }
    let decoded = percent_decode_utf8(uri)?;
    if decoded.is_empty() {
        return Err("empty URI".to_string());
    }
    Ok(UriTarget::File(base_dir.join(decoded)))
}

fn percent_decode_utf8(s: &str) -> Result<String, String> {
    String::from_utf8(percent_decode(s)?)
        .map_err(|_| "percent-decoded URI is not valid UTF-8".to_string())
}

/// Decodes `%XX` escapes.
pub(crate) fn percent_decode(s: &str) -> Result<Vec<u8>, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = |c: u8| (c as char).to_digit(16);
            match (
                b.get(i + 1).copied().and_then(hex),
                b.get(i + 2).copied().and_then(hex),
            ) {
                (Some(h), Some(l)) => {
                    out.push((h * 16 + l) as u8);
                    i += 3;
                }
                _ => return Err("bad percent escape in URI".to_string()),
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    Ok(out)
}

fn b64_value(c: u8) -> Option<u32> {
    match c {
        b'A'..=b'Z' => Some((c - b'A') as u32),
        b'a'..=b'z' => Some((c - b'a') as u32 + 26),
        b'0'..=b'9' => Some((c - b'0') as u32 + 52),
        b'+' | b'-' => Some(62),
        b'/' | b'_' => Some(63),
        _ => None,
    }
}

/// Decodes standard or URL-safe base64; padding is optional, ASCII whitespace is skipped.
pub(crate) fn base64_decode(s: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3 + 3);
    let mut acc: u32 = 0;
    let mut bits = 0u32;
    let mut padding = 0usize;
    for (pos, &c) in s.as_bytes().iter().enumerate() {
        if c.is_ascii_whitespace() {
            continue;
        }
        if c == b'=' {
            padding += 1;
            if padding > 2 {
                return Err(format!("too much padding at byte {pos}"));
            }
            continue;
        }
        if padding > 0 {
            return Err(format!("data after padding at byte {pos}"));
        }
        let Some(v) = b64_value(c) else {
            return Err(format!("invalid character {:?} at byte {pos}", c as char));
        };
        acc = (acc << 6) | v;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    if bits >= 6 {
        return Err("truncated base64 data".to_string());
    }
    Ok(out)
}

/// Encodes standard base64 with padding.
pub(crate) fn base64_encode(data: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trip() {
        for len in 0..40 {
            let data: Vec<u8> = (0..len).map(|i| (i * 37 + 11) as u8).collect();
            let enc = base64_encode(&data);
            assert_eq!(base64_decode(&enc).unwrap(), data);
            assert_eq!(base64_decode(enc.trim_end_matches('=')).unwrap(), data);
        }
        assert_eq!(base64_decode("aGVsbG8=").unwrap(), b"hello");
        assert!(base64_decode("a").is_err());
        assert!(base64_decode("a*bc").is_err());
        assert!(base64_decode("ab=c").is_err());
    }

    #[test]
    fn uris() {
        let base = Path::new("/scenes");
        assert_eq!(
            resolve("a%20b.bin", base).unwrap(),
            UriTarget::File(PathBuf::from("/scenes/a b.bin"))
        );
        assert_eq!(
            resolve("data:application/octet-stream;base64,AAEC", base).unwrap(),
            UriTarget::Data("application/octet-stream".into(), vec![0, 1, 2])
        );
        assert!(resolve("https://example.com/x.bin", base).is_err());
        assert!(resolve("%FF%FE", base).is_err());
        assert!(resolve("%4", base).is_err());
        assert!(resolve("data:xyz", base).is_err());
    }
}
