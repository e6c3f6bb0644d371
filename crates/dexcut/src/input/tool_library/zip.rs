//! The JSON inside a Fusion 360 `.tools` file, a zip archive holding
//! `tools.json`: the central directory read by hand (stored or deflated
//! entries, flate2 for the latter), the entry bounded in size.

use std::io::Read as _;

use super::MAX_LIBRARY_BYTES;
use crate::error::{fail, Result};

fn u16_at(b: &[u8], at: usize) -> Option<usize> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?) as usize)
}

fn u32_at(b: &[u8], at: usize) -> Option<usize> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?) as usize)
}

/// The first `.json` entry of the zip archive `bytes` (`file` in
/// messages): its name and content.
pub(crate) fn json_entry(bytes: &[u8], file: &str) -> Result<(String, Vec<u8>)> {
    let bad = |what: &str| -> Result<(String, Vec<u8>)> {
        fail!(
            job,
            "{file}: a zip archive that cannot be read ({what}): unzip it and give its tools.json"
        )
    };
    // End of central directory: the last "PK\5\6" within the 64 KiB comment.
    let from = bytes.len().saturating_sub(22 + 65_535);
    let Some(eocd) = (from..bytes.len().saturating_sub(21))
        .rev()
        .find(|&i| bytes[i..].starts_with(b"PK\x05\x06"))
    else {
        return bad("no end of central directory");
    };
    let (Some(count), Some(mut at)) = (u16_at(bytes, eocd + 10), u32_at(bytes, eocd + 16)) else {
        return bad("a short end of central directory");
    };
    for _ in 0..count {
        if !bytes
            .get(at..)
            .is_some_and(|b| b.starts_with(b"PK\x01\x02"))
        {
            return bad("a broken central directory");
        }
        let (
            Some(method),
            Some(size),
            Some(unpacked),
            Some(name_len),
            Some(extra),
            Some(note),
            Some(local),
        ) = (
            u16_at(bytes, at + 10),
            u32_at(bytes, at + 20),
            u32_at(bytes, at + 24),
            u16_at(bytes, at + 28),
            u16_at(bytes, at + 30),
            u16_at(bytes, at + 32),
            u32_at(bytes, at + 42),
        )
        else {
            return bad("a short central directory entry");
        };
        let Some(name) = bytes.get(at + 46..at + 46 + name_len) else {
            return bad("a short entry name");
        };
        let name = String::from_utf8_lossy(name).to_string();
        at += 46 + name_len + extra + note;
        if !name.to_ascii_lowercase().ends_with(".json") {
            continue;
        }
        if unpacked as u64 > MAX_LIBRARY_BYTES {
            fail!(
                limits,
                "{file}: {name} unpacks to {unpacked} bytes, more than the {MAX_LIBRARY_BYTES} a tool library may have"
            );
        }
        let (Some(local_name), Some(local_extra)) =
            (u16_at(bytes, local + 26), u16_at(bytes, local + 28))
        else {
            return bad("a short local header");
        };
        let start = local + 30 + local_name + local_extra;
        let Some(data) = bytes.get(start..start + size) else {
            return bad("an entry past the end of the file");
        };
        let mut out = Vec::with_capacity(unpacked);
        match method {
            0 => out.extend_from_slice(data),
            8 => {
                let read = flate2::read::DeflateDecoder::new(data)
                    .take(MAX_LIBRARY_BYTES + 1)
                    .read_to_end(&mut out);
                if read.is_err() || out.len() as u64 > MAX_LIBRARY_BYTES {
                    return bad("an entry that does not inflate");
                }
            }
            m => return bad(&format!("compression method {m}")),
        }
        return Ok((name, out));
    }
    bad("no .json entry")
}
