//! Per-packet compression of AEDAT 4 files: every packet body is compressed on its own
//! (an LZ4 frame or a zstd frame), as the `IOHeader` declares for the whole file.

use std::io::{Read, Write};

use super::Compression;

/// Decompresses one packet body into `out` (cleared first). Output beyond
/// `limit_bytes` is refused, so a small hostile packet cannot expand to gigabytes.
pub(super) fn decompress(
    compression: Compression,
    input: &[u8],
    out: &mut Vec<u8>,
    limit_bytes: u64,
) -> Result<(), String> {
    out.clear();
    let got = match compression {
        Compression::None => {
            out.extend_from_slice(input);
            input.len() as u64
        }
        Compression::Lz4 | Compression::Lz4High => {
            let decoder = lz4_flex::frame::FrameDecoder::new(input);
            read_limited(decoder, out, limit_bytes).map_err(|e| format!("LZ4 frame: {e}"))?
        }
        Compression::Zstd | Compression::ZstdHigh => {
            let decoder = zstd::stream::read::Decoder::with_buffer(input)
                .map_err(|e| format!("zstd frame: {e}"))?;
            read_limited(decoder, out, limit_bytes).map_err(|e| format!("zstd frame: {e}"))?
        }
    };
    if got > limit_bytes {
        return Err(format!("decompresses to more than {limit_bytes} bytes"));
    }
    Ok(())
}

fn read_limited(decoder: impl Read, out: &mut Vec<u8>, limit_bytes: u64) -> std::io::Result<u64> {
    let got = decoder.take(limit_bytes + 1).read_to_end(out)?;
    Ok(got as u64)
}

/// Compresses one packet body into `out` (cleared first).
///
/// `Lz4High` is written by the same LZ4 encoder as `Lz4`: the frames are the same
/// format and any LZ4 decoder reads both; only the encoder's effort differs.
pub(super) fn compress(
    compression: Compression,
    input: &[u8],
    out: &mut Vec<u8>,
) -> std::io::Result<()> {
    out.clear();
    match compression {
        Compression::None => out.extend_from_slice(input),
        Compression::Lz4 | Compression::Lz4High => {
            let mut encoder = lz4_flex::frame::FrameEncoder::new(std::mem::take(out));
            encoder.write_all(input)?;
            *out = encoder.finish().map_err(std::io::Error::other)?;
        }
        Compression::Zstd => *out = zstd::bulk::compress(input, ZSTD_LEVEL)?,
        Compression::ZstdHigh => *out = zstd::bulk::compress(input, ZSTD_HIGH_LEVEL)?,
    }
    Ok(())
}

/// zstd's default level, fast enough to record a flight on the drone's computer.
const ZSTD_LEVEL: i32 = 3;
/// A strong level for archives; far slower to write, as fast to read.
const ZSTD_HIGH_LEVEL: i32 = 19;
