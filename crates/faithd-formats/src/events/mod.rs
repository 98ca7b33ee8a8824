//! Recorded event files: streaming readers (and writers) for the formats DVS
//! recordings come in.
//!
//! Readers wrap any [`std::io::Read`] and hand out events one packet or one block at a
//! time, so a recording of any length is replayed in constant memory. Every format
//! implements [`EventReader`]; [`open_events`] picks the format from the file's
//! signature so callers never name it.
//!
//! | format | module | read | write |
//! | --- | --- | --- | --- |
//! | AEDAT 2.0 (jAER, DAVIS240 addresses) | [`aedat2`] | yes | yes |
//! | AEDAT 3.1 (cAER / libcaer) | [`aedat3`] | yes | yes |
//! | AEDAT 4.0 (DV, flatbuffers, LZ4/zstd) | [`aedat4`] | yes | yes |
//! | text `t x y p`, t in seconds | [`text`] | yes | yes |

pub mod aedat2;
pub mod aedat3;
pub mod aedat4;
mod counted;
mod error;
pub mod text;

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

pub use error::SourceError;

use faithd_core::event::Event;

/// A stream of events from a recording, read a batch at a time.
///
/// Batches keep the per-event cost of the trait object out of the hot loop: the caller
/// reuses one `Vec` and the reader fills it with the next packet (AEDAT 3/4) or block
/// of records (AEDAT 2, text).
pub trait EventReader {
    /// Replaces the contents of `out` with the next events of the file, in file order.
    /// Returns `Ok(false)` with `out` empty at the end of the file, `Ok(true)` otherwise
    /// (a batch may be empty when a packet held no valid events).
    fn next_batch(&mut self, out: &mut Vec<Event>) -> Result<bool, SourceError>;

    /// Which format is being read.
    fn format(&self) -> Format;
}

impl<T: EventReader + ?Sized> EventReader for Box<T> {
    fn next_batch(&mut self, out: &mut Vec<Event>) -> Result<bool, SourceError> {
        (**self).next_batch(out)
    }

    fn format(&self) -> Format {
        (**self).format()
    }
}

/// The recorded-event formats faithd understands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Aedat2,
    Aedat3,
    Aedat4,
    Text,
}

/// The first bytes of each AEDAT version, which is how files say what they are.
pub const AEDAT2_MAGIC: &[u8] = b"#!AER-DAT2.0";
pub const AEDAT3_MAGIC: &[u8] = b"#!AER-DAT3.1";
pub const AEDAT4_MAGIC: &[u8] = b"#!AER-DAT4.0";

/// Tells the format from the first bytes of a file (at least 12 are needed to see an
/// AEDAT signature); anything that is not AEDAT is taken as text.
///
/// A file that starts with `#!AER-DAT` but names another version is not text either:
/// it is reported as a bad magic rather than parsed line by line into nonsense.
pub fn detect_format(prefix: &[u8]) -> Result<Format, SourceError> {
    if prefix.starts_with(AEDAT2_MAGIC) {
        Ok(Format::Aedat2)
    } else if prefix.starts_with(AEDAT3_MAGIC) {
        Ok(Format::Aedat3)
    } else if prefix.starts_with(AEDAT4_MAGIC) {
        Ok(Format::Aedat4)
    } else if prefix.starts_with(b"#!AER-DAT") {
        Err(SourceError::BadMagic {
            offset_bytes: 0,
            expected: "#!AER-DAT2.0, #!AER-DAT3.1 or #!AER-DAT4.0",
            found: String::from_utf8_lossy(&prefix[..prefix.len().min(16)]).into_owned(),
        })
    } else {
        Ok(Format::Text)
    }
}

/// Opens a recorded event file of any supported format, detected from its header.
///
/// A file with an `.aedat*` extension must carry an AEDAT signature: without it the
/// file is damaged, and reading it as text would only produce a confusing line error.
pub fn open_events(path: impl AsRef<Path>) -> Result<Box<dyn EventReader>, SourceError> {
    let path = path.as_ref();
    let open_error = |source| SourceError::Open {
        path: path.to_path_buf(),
        source,
    };
    let mut file = File::open(path).map_err(open_error)?;
    let mut prefix = [0u8; 16];
    let mut got = 0;
    while got < prefix.len() {
        match file.read(&mut prefix[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(open_error(e)),
        }
    }
    file.seek(SeekFrom::Start(0)).map_err(open_error)?;
    let format = detect_format(&prefix[..got])?;
    let says_aedat = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.to_ascii_lowercase().starts_with("aedat"));
    if format == Format::Text && says_aedat {
        return Err(SourceError::BadMagic {
            offset_bytes: 0,
            expected: "#!AER-DAT2.0, #!AER-DAT3.1 or #!AER-DAT4.0",
            found: String::from_utf8_lossy(&prefix[..got]).into_owned(),
        });
    }
    open_reader(file, format)
}

/// Builds the reader for `format` over any byte source.
pub fn open_reader<R: Read + 'static>(
    input: R,
    format: Format,
) -> Result<Box<dyn EventReader>, SourceError> {
    Ok(match format {
        Format::Aedat2 => Box::new(aedat2::Aedat2Reader::new(input)?),
        Format::Aedat3 => Box::new(aedat3::Aedat3Reader::new(input)?),
        Format::Aedat4 => Box::new(aedat4::Aedat4Reader::new(input)?),
        Format::Text => Box::new(text::TextReader::new(input)),
    })
}

/// One event at a time over any [`EventReader`], for callers that do not care about
/// batches (tests, tools). Stops after the first error.
pub struct Events<E> {
    reader: E,
    batch: Vec<Event>,
    next_index: usize,
    finished: bool,
}

impl<E: EventReader> Events<E> {
    pub fn new(reader: E) -> Self {
        Self {
            reader,
            batch: Vec::new(),
            next_index: 0,
            finished: false,
        }
    }
}

impl<E: EventReader> Iterator for Events<E> {
    type Item = Result<Event, SourceError>;

    fn next(&mut self) -> Option<Self::Item> {
        while self.next_index >= self.batch.len() {
            if self.finished {
                return None;
            }
            self.next_index = 0;
            match self.reader.next_batch(&mut self.batch) {
                Ok(true) => {}
                Ok(false) => {
                    self.finished = true;
                    return None;
                }
                Err(e) => {
                    self.finished = true;
                    self.batch.clear();
                    return Some(Err(e));
                }
            }
        }
        let event = self.batch[self.next_index];
        self.next_index += 1;
        Some(Ok(event))
    }
}

/// Reads every remaining event; for tests and small files only, as it holds them all.
pub fn read_all(reader: &mut dyn EventReader) -> Result<Vec<Event>, SourceError> {
    let mut all = Vec::new();
    let mut batch = Vec::new();
    while reader.next_batch(&mut batch)? {
        all.extend_from_slice(&batch);
    }
    Ok(all)
}
