//! A buffered reader that knows how far into the file it is.
//!
//! Every format reader goes through it, so every error can name the byte offset where
//! the bad field starts, and every size read from a file is read with `take` so memory
//! grows with the bytes that are really there, never with what a header claims.

use std::io::{self, BufRead, BufReader, Read};

use super::SourceError;

/// Byte-offset-tracking wrapper over a buffered reader.
pub(crate) struct CountedReader<R> {
    inner: BufReader<R>,
    offset_bytes: u64,
}

impl<R: Read> CountedReader<R> {
    pub(crate) fn new(inner: R) -> Self {
        Self {
            inner: BufReader::with_capacity(64 * 1024, inner),
            offset_bytes: 0,
        }
    }

    /// Offset of the next byte to be read, from the start of the file.
    pub(crate) fn offset_bytes(&self) -> u64 {
        self.offset_bytes
    }

    fn io_error(&self, source: io::Error) -> SourceError {
        SourceError::Io {
            offset_bytes: self.offset_bytes,
            source,
        }
    }

    /// Fills `buf` completely, or returns `Ok(false)` if the file ends cleanly before
    /// its first byte; a file ending inside `buf` is a [`SourceError::Truncated`].
    pub(crate) fn read_exact_or_eof(
        &mut self,
        buf: &mut [u8],
        field: &'static str,
    ) -> Result<bool, SourceError> {
        let start = self.offset_bytes;
        let mut got = 0;
        while got < buf.len() {
            match self.inner.read(&mut buf[got..]) {
                Ok(0) => break,
                Ok(n) => {
                    got += n;
                    self.offset_bytes += n as u64;
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io_error(e)),
            }
        }
        if got == buf.len() {
            Ok(true)
        } else if got == 0 {
            Ok(false)
        } else {
            Err(SourceError::Truncated {
                field,
                offset_bytes: start,
                needed_bytes: buf.len() as u64,
                got_bytes: got as u64,
            })
        }
    }

    /// Fills `buf` completely; the file ending anywhere inside it is an error.
    pub(crate) fn read_exact(
        &mut self,
        buf: &mut [u8],
        field: &'static str,
    ) -> Result<(), SourceError> {
        let start = self.offset_bytes;
        if self.read_exact_or_eof(buf, field)? {
            Ok(())
        } else {
            Err(SourceError::Truncated {
                field,
                offset_bytes: start,
                needed_bytes: buf.len() as u64,
                got_bytes: 0,
            })
        }
    }

    /// Replaces the contents of `out` with the next `len_bytes` bytes. The vector grows
    /// only as bytes arrive, so a huge `len_bytes` on a short file costs nothing.
    pub(crate) fn read_into(
        &mut self,
        len_bytes: u64,
        out: &mut Vec<u8>,
        field: &'static str,
    ) -> Result<(), SourceError> {
        let start = self.offset_bytes;
        out.clear();
        let got = (&mut self.inner)
            .take(len_bytes)
            .read_to_end(out)
            .map_err(|e| self.io_error(e))?;
        self.offset_bytes += got as u64;
        if (got as u64) < len_bytes {
            return Err(SourceError::Truncated {
                field,
                offset_bytes: start,
                needed_bytes: len_bytes,
                got_bytes: got as u64,
            });
        }
        Ok(())
    }

    /// Reads past `len_bytes` bytes without keeping them.
    pub(crate) fn skip(&mut self, len_bytes: u64, field: &'static str) -> Result<(), SourceError> {
        let start = self.offset_bytes;
        let got = io::copy(&mut (&mut self.inner).take(len_bytes), &mut io::sink())
            .map_err(|e| self.io_error(e))?;
        self.offset_bytes += got;
        if got < len_bytes {
            return Err(SourceError::Truncated {
                field,
                offset_bytes: start,
                needed_bytes: len_bytes,
                got_bytes: got,
            });
        }
        Ok(())
    }

    /// Reads the signature a format starts with. A file that is shorter than the
    /// signature or starts with other bytes is not this format: [`SourceError::BadMagic`]
    /// at byte 0, showing what was found.
    pub(crate) fn expect_magic(
        &mut self,
        magic: &[u8],
        expected: &'static str,
    ) -> Result<(), SourceError> {
        let mut found = Vec::with_capacity(magic.len());
        (&mut self.inner)
            .take(magic.len() as u64)
            .read_to_end(&mut found)
            .map_err(|e| self.io_error(e))?;
        self.offset_bytes += found.len() as u64;
        if found == magic {
            Ok(())
        } else {
            Err(SourceError::BadMagic {
                offset_bytes: 0,
                expected,
                found: String::from_utf8_lossy(&found).into_owned(),
            })
        }
    }

    /// Whether the buffered bytes ahead start a `#` text line: `#`, then text (UTF-8, no
    /// control characters but tab and CR) up to a `\n`. AEDAT 2 has no end-of-header
    /// marker and a binary record can start with `#` (0x23), so a header line is told
    /// apart from data by being text. A line longer than the buffer counts as text.
    pub(crate) fn at_text_line(&mut self) -> Result<bool, SourceError> {
        let ahead = loop {
            match self.inner.fill_buf() {
                Ok(buf) => break buf,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io_error(e)),
            }
        };
        if ahead.first() != Some(&b'#') {
            return Ok(false);
        }
        let line = match ahead.iter().position(|&b| b == b'\n') {
            Some(end) => &ahead[..end],
            None => ahead,
        };
        let is_text = match std::str::from_utf8(line) {
            Ok(text) => !text
                .chars()
                .any(|c| c.is_control() && c != '\t' && c != '\r'),
            // A multi-byte character cut by the end of the buffer is still text.
            Err(error) => error.error_len().is_none() && ahead.len() == line.len(),
        };
        Ok(is_text)
    }

    /// Reads one line including its `\n` into `out` (cleared first). A line longer than
    /// `max_len_bytes` is a [`SourceError::TooLarge`]. Returns `false` at end of file.
    pub(crate) fn read_line(
        &mut self,
        out: &mut Vec<u8>,
        max_len_bytes: u64,
        field: &'static str,
    ) -> Result<bool, SourceError> {
        let start = self.offset_bytes;
        out.clear();
        let got = (&mut self.inner)
            .take(max_len_bytes + 1)
            .read_until(b'\n', out)
            .map_err(|e| self.io_error(e))?;
        self.offset_bytes += got as u64;
        if got as u64 > max_len_bytes {
            return Err(SourceError::TooLarge {
                field,
                offset_bytes: start,
                value: got as u64,
                limit: max_len_bytes,
            });
        }
        Ok(got > 0)
    }
}

/// Reads the `#` comment lines that open AEDAT 2 and 3 files.
///
/// Stops before the first byte that does not start a `#` line, or right after a line
/// equal to `end_line` (AEDAT 3's `#!END-HEADER`) when one is given. Returns whether
/// `end_line` was seen. The header is capped in total size so a file of endless `#`
/// lines fails instead of looping over gigabytes.
pub(crate) fn read_hash_header<R: Read>(
    reader: &mut CountedReader<R>,
    end_line: Option<&[u8]>,
) -> Result<bool, SourceError> {
    const MAX_LINE_BYTES: u64 = 64 * 1024;
    const MAX_HEADER_BYTES: u64 = 16 * 1024 * 1024;
    let mut line = Vec::new();
    while reader.at_text_line()? {
        if reader.offset_bytes() > MAX_HEADER_BYTES {
            return Err(SourceError::TooLarge {
                field: "header",
                offset_bytes: 0,
                value: reader.offset_bytes(),
                limit: MAX_HEADER_BYTES,
            });
        }
        reader.read_line(&mut line, MAX_LINE_BYTES, "header line")?;
        if let Some(end) = end_line {
            let trimmed = line.strip_suffix(b"\n").unwrap_or(&line);
            let trimmed = trimmed.strip_suffix(b"\r").unwrap_or(trimmed);
            if trimmed == end {
                return Ok(true);
            }
        }
    }
    Ok(false)
}
