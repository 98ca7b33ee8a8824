//! Plain-text events as published by the public event-camera datasets: one event per
//! line, `t x y p`, with `t` in seconds (e.g. `0.003811000 96 133 0`).
//!
//! Times are parsed as exact decimals, not through `f64`, so a timestamp written with
//! microsecond digits comes back as exactly that microsecond; digits beyond the
//! microsecond are rounded half away from zero. Blank lines and lines starting with `#`
//! are skipped; fields may be separated by spaces, tabs or commas. Polarity is `1` for
//! on, and `0` or `-1` for off.

use std::io::{Read, Write};

use super::counted::CountedReader;
use super::{EventReader, Format, SourceError};
use faithd_core::event::{Event, Polarity};

/// Longest accepted line; real lines are under 40 bytes.
const MAX_LINE_BYTES: u64 = 4096;
/// Events per batch handed out by [`TextReader::next_batch`].
const BATCH_EVENTS: usize = 4096;

/// Streaming reader of `t x y p` text files.
pub struct TextReader<R> {
    input: CountedReader<R>,
    line: Vec<u8>,
    line_number: u64,
}

impl<R: Read> TextReader<R> {
    pub fn new(input: R) -> Self {
        Self {
            input: CountedReader::new(input),
            line: Vec::with_capacity(64),
            line_number: 0,
        }
    }
}

impl<R: Read> EventReader for TextReader<R> {
    fn next_batch(&mut self, out: &mut Vec<Event>) -> Result<bool, SourceError> {
        out.clear();
        while out.len() < BATCH_EVENTS {
            let line_start_bytes = self.input.offset_bytes();
            let more = self
                .input
                .read_line(&mut self.line, MAX_LINE_BYTES, "text line")
                .map_err(|e| match e {
                    SourceError::TooLarge { limit, .. } => SourceError::TextLine {
                        line: self.line_number + 1,
                        offset_bytes: line_start_bytes,
                        reason: format!("line longer than {limit} bytes"),
                    },
                    other => other,
                })?;
            if !more {
                break;
            }
            self.line_number += 1;
            let line_error = |reason: String| SourceError::TextLine {
                line: self.line_number,
                offset_bytes: line_start_bytes,
                reason,
            };
            let text = std::str::from_utf8(&self.line)
                .map_err(|_| line_error("not valid UTF-8".to_string()))?;
            if let Some(event) = parse_line(text).map_err(line_error)? {
                out.push(event);
            }
        }
        Ok(!out.is_empty())
    }

    fn format(&self) -> Format {
        Format::Text
    }
}

/// Parses one line; `Ok(None)` for blank and comment lines.
fn parse_line(line: &str) -> Result<Option<Event>, String> {
    let trimmed = line.trim();
    if trimmed.is_empty() || trimmed.starts_with('#') {
        return Ok(None);
    }
    let mut fields = trimmed
        .split(|c: char| c.is_ascii_whitespace() || c == ',')
        .filter(|f| !f.is_empty());
    let mut next = |name: &str| {
        fields
            .next()
            .ok_or_else(|| format!("missing field {name} (expected \"t x y p\")"))
    };
    let t_field = next("t")?;
    let x_field = next("x")?;
    let y_field = next("y")?;
    let p_field = next("p")?;
    if let Some(extra) = fields.next() {
        return Err(format!(
            "unexpected fifth field {extra:?} (expected \"t x y p\")"
        ));
    }
    let t_us = parse_seconds_as_us(t_field).ok_or_else(|| format!("bad time t {t_field:?}"))?;
    let x_px: u16 = x_field
        .parse()
        .map_err(|_| format!("bad x {x_field:?} (0..=65535)"))?;
    let y_px: u16 = y_field
        .parse()
        .map_err(|_| format!("bad y {y_field:?} (0..=65535)"))?;
    let polarity = match p_field {
        "1" | "+1" => Polarity::On,
        "0" | "-1" => Polarity::Off,
        other => return Err(format!("bad polarity {other:?} (0, 1 or -1)")),
    };
    Ok(Some(Event::new(t_us, x_px, y_px, polarity)))
}

/// Seconds written as a decimal (`12.000345`, `-0.5`, `3`) to whole microseconds,
/// exactly for up to six decimals; scientific notation goes through `f64`.
fn parse_seconds_as_us(field: &str) -> Option<i64> {
    if field.contains(['e', 'E']) {
        let s: f64 = field.parse().ok()?;
        let us = (s * 1e6).round();
        return (us.is_finite() && us.abs() < 9.0e18).then_some(us as i64);
    }
    let (negative, digits) = match field.as_bytes().first()? {
        b'-' => (true, &field[1..]),
        b'+' => (false, &field[1..]),
        _ => (false, field),
    };
    let (whole, fraction) = digits.split_once('.').unwrap_or((digits, ""));
    if whole.is_empty() && fraction.is_empty() {
        return None;
    }
    if !whole.bytes().all(|b| b.is_ascii_digit()) || !fraction.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let whole_s: i64 = if whole.is_empty() {
        0
    } else {
        whole.parse().ok()?
    };
    let mut fraction_us: i64 = 0;
    for (i, digit) in fraction.bytes().enumerate() {
        let d = i64::from(digit - b'0');
        if i < 6 {
            fraction_us = fraction_us * 10 + d;
        } else {
            if i == 6 && d >= 5 {
                fraction_us += 1;
            }
            break;
        }
    }
    for _ in fraction.len()..6 {
        fraction_us *= 10;
    }
    let us = whole_s.checked_mul(1_000_000)?.checked_add(fraction_us)?;
    Some(if negative { -us } else { us })
}

/// Writes events as `t x y p` lines with `t` in seconds and microsecond digits, the
/// layout the datasets use, so a text recording round-trips exactly.
pub struct TextWriter<W: Write> {
    output: W,
    written_bytes: u64,
}

impl<W: Write> TextWriter<W> {
    pub fn new(output: W) -> Self {
        Self {
            output,
            written_bytes: 0,
        }
    }

    pub fn write_events(&mut self, events: &[Event]) -> Result<(), SourceError> {
        let mut text = String::with_capacity(events.len() * 28);
        for event in events {
            use std::fmt::Write as _;
            let sign = if event.t_us < 0 { "-" } else { "" };
            let magnitude_us = event.t_us.unsigned_abs();
            let _ = writeln!(
                text,
                "{sign}{}.{:06} {} {} {}",
                magnitude_us / 1_000_000,
                magnitude_us % 1_000_000,
                event.x_px,
                event.y_px,
                event.polarity.index()
            );
        }
        self.output
            .write_all(text.as_bytes())
            .map_err(|e| SourceError::write_io(e, self.written_bytes))?;
        self.written_bytes += text.len() as u64;
        Ok(())
    }

    /// Flushes and hands back the output.
    pub fn finish(mut self) -> Result<W, SourceError> {
        self.output
            .flush()
            .map_err(|e| SourceError::write_io(e, self.written_bytes))?;
        Ok(self.output)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_parse_exactly_to_microseconds() {
        assert_eq!(parse_seconds_as_us("0.003811000"), Some(3811));
        assert_eq!(parse_seconds_as_us("12.5"), Some(12_500_000));
        assert_eq!(parse_seconds_as_us("3"), Some(3_000_000));
        assert_eq!(parse_seconds_as_us(".000001"), Some(1));
        assert_eq!(parse_seconds_as_us("-0.000002"), Some(-2));
        assert_eq!(parse_seconds_as_us("0.0000015"), Some(2));
        assert_eq!(parse_seconds_as_us("1e-3"), Some(1000));
        assert_eq!(parse_seconds_as_us("1.2.3"), None);
        assert_eq!(parse_seconds_as_us("-"), None);
        assert_eq!(parse_seconds_as_us("."), None);
        assert_eq!(parse_seconds_as_us("99999999999999999999"), None);
    }
}
