//! Recorded event files: round trips through faithd's writers, hand-built byte
//! fixtures per format, damaged input, and a seeded mutation corpus (a cheap fuzz).

use std::io::Cursor;

use faithd_core::event::{Event, Polarity};
use faithd_formats::events::aedat2::{Aedat2Reader, Aedat2Writer};
use faithd_formats::events::aedat3::{Aedat3Reader, Aedat3Writer};
use faithd_formats::events::aedat4::{Aedat4Config, Aedat4Reader, Aedat4Writer, Compression};
use faithd_formats::events::text::{TextReader, TextWriter};
use faithd_formats::events::{
    EventReader, Events, Format, SourceError, open_events, open_reader, read_all,
};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

fn ev(t_us: i64, x_px: u16, y_px: u16, on: bool) -> Event {
    Event::new(t_us, x_px, y_px, Polarity::from_bool(on))
}

fn aedat2_bytes(events: &[Event]) -> Vec<u8> {
    let mut writer = Aedat2Writer::new(Vec::new()).unwrap();
    writer.write_events(events).unwrap();
    writer.finish().unwrap()
}

fn aedat3_bytes(events: &[Event]) -> Vec<u8> {
    let mut writer = Aedat3Writer::new(Vec::new()).unwrap();
    writer.write_events(events).unwrap();
    writer.finish().unwrap()
}

fn aedat4_bytes(events: &[Event], compression: Compression) -> Vec<u8> {
    let config = Aedat4Config {
        compression,
        ..Aedat4Config::default()
    };
    let mut writer = Aedat4Writer::new(Cursor::new(Vec::new()), config).unwrap();
    for batch in events.chunks(50) {
        writer.write_events(batch).unwrap();
    }
    writer.finish().unwrap().into_inner()
}

fn text_bytes(events: &[Event]) -> Vec<u8> {
    let mut writer = TextWriter::new(Vec::new());
    writer.write_events(events).unwrap();
    writer.finish().unwrap()
}

fn read_bytes(bytes: &[u8], format: Format) -> Result<Vec<Event>, SourceError> {
    let mut reader = open_reader(Cursor::new(bytes.to_vec()), format)?;
    read_all(&mut *reader)
}

/// Sorted events on the 240x180 sensor, times from `t0_us` with steps below `max_step_us`.
fn sorted_events(t0_us: i64, max_step_us: i64) -> impl Strategy<Value = Vec<Event>> {
    prop::collection::vec(
        (0..max_step_us, 0u16..240, 0u16..180, any::<bool>()),
        0..300,
    )
    .prop_map(move |raw| {
        let mut t_us = t0_us;
        raw.into_iter()
            .map(|(step, x, y, on)| {
                t_us += step;
                ev(t_us, x, y, on)
            })
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn aedat2_round_trips(events in sorted_events(0, 40_000_000)) {
        prop_assert_eq!(read_bytes(&aedat2_bytes(&events), Format::Aedat2).unwrap(), events);
    }

    #[test]
    fn aedat3_round_trips(events in sorted_events(1 << 30, 1 << 28)) {
        prop_assert_eq!(read_bytes(&aedat3_bytes(&events), Format::Aedat3).unwrap(), events);
    }

    #[test]
    fn aedat4_round_trips(events in sorted_events(1_700_000_000_000_000, 1_000), compression in 0usize..5) {
        let bytes = aedat4_bytes(&events, Compression::ALL[compression]);
        prop_assert_eq!(read_bytes(&bytes, Format::Aedat4).unwrap(), events);
    }

    #[test]
    fn text_round_trips(events in sorted_events(-5_000_000, 10_000_000)) {
        prop_assert_eq!(read_bytes(&text_bytes(&events), Format::Text).unwrap(), events);
    }
}

/// A record whose first byte is `#` (0x23) is data, not another header line: faithd's
/// files end their header with jAER's `#End Of ASCII Header`, and the reader stops there.
#[test]
fn aedat2_record_starting_with_a_hash_is_not_header() {
    // Row 36 from the top is raw row 143: address 0x23C0_0000.
    let events = vec![ev(0, 0, 36, false), ev(5, 3, 36, true)];
    let bytes = aedat2_bytes(&events);
    let first_record = bytes.len() - 16;
    assert_eq!(bytes[first_record], b'#');
    assert_eq!(read_bytes(&bytes, Format::Aedat2).unwrap(), events);
}

/// The case the property test found: column 160, raw row 140 makes the address
/// 0x230A_0000, whose first two bytes read as the text line "#\n".
#[test]
fn aedat2_record_that_reads_as_a_text_line_round_trips() {
    let events = vec![ev(0, 160, 39, false)];
    let bytes = aedat2_bytes(&events);
    assert_eq!(&bytes[bytes.len() - 8..bytes.len() - 6], b"#\n");
    assert_eq!(read_bytes(&bytes, Format::Aedat2).unwrap(), events);
    // Every row and column whose address starts with '#' and a line end.
    let tricky: Vec<Event> = (0..180u16)
        .flat_map(|y| (0..240u16).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let address = (u32::from(179 - y) << 22) | (u32::from(x) << 12);
            address >> 24 == 0x23 && matches!((address >> 16) & 0xFF, 0x0A | 0x0D)
        })
        .enumerate()
        .map(|(i, (x, y))| ev(i as i64, x, y, false))
        .collect();
    assert!(!tricky.is_empty());
    assert_eq!(
        read_bytes(&aedat2_bytes(&tricky), Format::Aedat2).unwrap(),
        tricky
    );
}

#[test]
fn aedat2_timestamps_unwrap_past_32_bits() {
    let events: Vec<Event> = (0..10).map(|i| ev(i * 1_000_000_000, 1, 2, true)).collect();
    assert_eq!(
        read_bytes(&aedat2_bytes(&events), Format::Aedat2).unwrap(),
        events
    );
}

#[test]
fn aedat3_packets_split_at_timestamp_overflow() {
    let events = vec![
        ev((1 << 31) - 1, 0, 0, false),
        ev(1 << 31, 1, 1, true),
        ev(5 << 31, 239, 179, true),
    ];
    let bytes = aedat3_bytes(&events);
    let mut reader = Aedat3Reader::new(Cursor::new(bytes)).unwrap();
    let mut batch = Vec::new();
    let mut batches = 0;
    while reader.next_batch(&mut batch).unwrap() {
        assert_eq!(batch.len(), 1);
        batches += 1;
    }
    assert_eq!(batches, 3);
}

// ---- hand-built fixtures ----------------------------------------------------------

#[test]
fn aedat2_fixture_skips_aps_and_imu_and_flips_rows() {
    let mut bytes = b"#!AER-DAT2.0\r\n# created by hand\r\n#\r\n".to_vec();
    let mut record = |address: u32, t_us: u32| {
        bytes.extend_from_slice(&address.to_be_bytes());
        bytes.extend_from_slice(&t_us.to_be_bytes());
    };
    record((10 << 22) | (5 << 12) | (1 << 11), 100); // DVS on at raw (5, 10)
    record(0x8000_0000 | (3 << 22), 101); // APS sample
    record((1 << 10) | 7, 102); // IMU sample
    record(179 << 22 | 239 << 12, 103); // DVS off at raw (239, 179)
    let events = read_bytes(&bytes, Format::Aedat2).unwrap();
    assert_eq!(
        events,
        vec![ev(100, 5, 179 - 10, true), ev(103, 239, 0, false)]
    );
}

fn aedat3_packet(
    event_type: i16,
    size: i32,
    overflow: i32,
    capacity: i32,
    number: i32,
    body: &[u8],
) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&event_type.to_le_bytes());
    out.extend_from_slice(&1i16.to_le_bytes());
    for field in [size, 4, overflow, capacity, number, number] {
        out.extend_from_slice(&field.to_le_bytes());
    }
    out.extend_from_slice(body);
    out
}

fn aedat3_header() -> Vec<u8> {
    b"#!AER-DAT3.1\r\n#Format: RAW\r\n#Source 1: DAVIS240C\r\n#!END-HEADER\r\n".to_vec()
}

#[test]
fn aedat3_fixture_skips_other_packets_and_invalid_events() {
    let mut bytes = aedat3_header();
    // A special-event packet (type 0), two 8-byte events: skipped whole.
    bytes.extend(aedat3_packet(0, 8, 0, 2, 2, &[0xAB; 16]));
    // A polarity packet in overflow epoch 1: valid on at (3, 4), an invalid event, and
    // a valid off at (239, 179), then unused capacity.
    let mut body = Vec::new();
    for (data, t_us) in [
        (1u32 | 2 | (4 << 2) | (3 << 17), 10i32),
        (2 | (9 << 2), 11),
        (1 | (179 << 2) | (239 << 17), 12),
        (1 | (1 << 2), 13),
    ] {
        body.extend_from_slice(&data.to_le_bytes());
        body.extend_from_slice(&t_us.to_le_bytes());
    }
    bytes.extend(aedat3_packet(1, 8, 1, 4, 3, &body));
    let events = read_bytes(&bytes, Format::Aedat3).unwrap();
    assert_eq!(
        events,
        vec![
            ev((1 << 31) | 10, 3, 4, true),
            ev((1 << 31) | 12, 239, 179, false)
        ]
    );
}

/// An AEDAT 4 file laid out differently from faithd's writer: the `IOHeader` has no
/// `dataTablePosition` (default -1) and its vtable comes after the table; a frame
/// stream's packet comes before the events and must be skipped.
fn aedat4_fixture() -> Vec<u8> {
    let info = "<dv version=\"2.0\"><node name=\"outInfo\" path=\"/outInfo/\">\
        <node name=\"0\" path=\"/outInfo/0/\"><attr key=\"typeIdentifier\" type=\"string\">FRME</attr></node>\
        <node name=\"1\" path=\"/outInfo/1/\"><attr key=\"typeIdentifier\" type=\"string\">EVTS</attr>\
        <node name=\"info\" path=\"/outInfo/1/info/\"><attr key=\"sizeX\" type=\"int\">240</attr>\
        <attr key=\"sizeY\" type=\"int\">180</attr></node></node></node></dv>";
    let mut header = Vec::new();
    header.extend_from_slice(&4u32.to_le_bytes()); // root table at 4
    header.extend_from_slice(&(-12i32).to_le_bytes()); // table at 4: vtable at 4 + 12 = 16
    header.extend_from_slice(&20u32.to_le_bytes()); // at 8: infoNode string at 8 + 20 = 28
    header.extend_from_slice(&[0; 4]);
    for value in [10u16, 8, 0, 0, 4] {
        header.extend_from_slice(&value.to_le_bytes()); // vtable at 16: only field 2, at +4
    }
    header.extend_from_slice(&[0; 2]);
    header.extend_from_slice(&(info.len() as u32).to_le_bytes()); // string at 28
    header.extend_from_slice(info.as_bytes());
    header.push(0);

    let mut bytes = b"#!AER-DAT4.0\r\n".to_vec();
    bytes.extend_from_slice(&(header.len() as i32).to_le_bytes());
    bytes.extend_from_slice(&header);
    // Frame packet, stream 0: 5 opaque bytes.
    bytes.extend_from_slice(&0i32.to_le_bytes());
    bytes.extend_from_slice(&5i32.to_le_bytes());
    bytes.extend_from_slice(&[1, 2, 3, 4, 5]);
    // Event packet, stream 1: size-prefixed EventPacket with two events.
    let mut packet = Vec::new();
    packet.extend_from_slice(&0u32.to_le_bytes()); // size prefix, set below
    packet.extend_from_slice(&16u32.to_le_bytes()); // root table at 16 (after prefix)
    packet.extend_from_slice(b"EVTS");
    for value in [6u16, 8, 4] {
        packet.extend_from_slice(&value.to_le_bytes()); // vtable at 8 (after prefix)
    }
    packet.extend_from_slice(&[0; 2]);
    packet.extend_from_slice(&8i32.to_le_bytes()); // table at 16 (after prefix): vtable 8 back
    packet.extend_from_slice(&4u32.to_le_bytes()); // vector at 20 + 4 = 24 (after prefix)
    packet.extend_from_slice(&2u32.to_le_bytes());
    for (t_us, x, y, p) in [(1_000_000i64, 17i16, 42i16, 1u8), (1_000_005, 239, 179, 0)] {
        packet.extend_from_slice(&t_us.to_le_bytes());
        packet.extend_from_slice(&x.to_le_bytes());
        packet.extend_from_slice(&y.to_le_bytes());
        packet.extend_from_slice(&[p, 0, 0, 0]);
    }
    let size = packet.len() as u32 - 4;
    packet[0..4].copy_from_slice(&size.to_le_bytes());
    bytes.extend_from_slice(&1i32.to_le_bytes());
    bytes.extend_from_slice(&(packet.len() as i32).to_le_bytes());
    bytes.extend_from_slice(&packet);
    bytes
}

#[test]
fn aedat4_fixture_reads_the_event_stream_only() {
    let bytes = aedat4_fixture();
    let mut reader = Aedat4Reader::new(Cursor::new(bytes)).unwrap();
    assert_eq!(reader.compression(), Compression::None);
    assert_eq!(reader.streams().len(), 2);
    assert_eq!(
        (reader.streams()[1].width_px, reader.streams()[1].height_px),
        (Some(240), Some(180))
    );
    let events = read_all(&mut reader).unwrap();
    assert_eq!(
        events,
        vec![ev(1_000_000, 17, 42, true), ev(1_000_005, 239, 179, false)]
    );
}

#[test]
fn text_fixture_with_comments_blank_lines_and_crlf() {
    let text = "# t x y p\r\n0.003811000 96 133 0\r\n\r\n  1.5\t3\t4\t1\n0.000001,1,2,-1\n# end";
    let events = read_bytes(text.as_bytes(), Format::Text).unwrap();
    assert_eq!(
        events,
        vec![
            ev(3811, 96, 133, false),
            ev(1_500_000, 3, 4, true),
            ev(1, 1, 2, false)
        ]
    );
}

#[test]
fn events_iterator_yields_one_event_at_a_time() {
    let events: Vec<Event> = (0..10_000)
        .map(|i| ev(i, (i % 240) as u16, (i % 180) as u16, i % 2 == 0))
        .collect();
    let reader = TextReader::new(Cursor::new(text_bytes(&events)));
    let back: Vec<Event> = Events::new(reader).collect::<Result<_, _>>().unwrap();
    assert_eq!(back, events);
}

#[test]
fn open_events_detects_every_format_by_signature() {
    let dir = std::env::temp_dir().join(format!("faithd-event-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let events = vec![ev(10, 1, 2, true), ev(20, 239, 179, false)];
    let files = [
        ("a.aedat", aedat2_bytes(&events), Format::Aedat2),
        ("b.aedat", aedat3_bytes(&events), Format::Aedat3),
        (
            "c.aedat4",
            aedat4_bytes(&events, Compression::Zstd),
            Format::Aedat4,
        ),
        ("d.txt", text_bytes(&events), Format::Text),
        ("e.dat", text_bytes(&events), Format::Text),
    ];
    for (name, bytes, format) in files {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let mut reader = open_events(&path).unwrap();
        assert_eq!(reader.format(), format, "{name}");
        assert_eq!(read_all(&mut *reader).unwrap(), events, "{name}");
    }
    let garbage = dir.join("garbage.aedat4");
    std::fs::write(&garbage, b"0.1 2 3 1\n").unwrap();
    assert!(matches!(
        open_events(&garbage),
        Err(SourceError::BadMagic {
            offset_bytes: 0,
            ..
        })
    ));
    let unknown_version = dir.join("v5.aedat");
    std::fs::write(&unknown_version, b"#!AER-DAT5.0\r\n").unwrap();
    assert!(matches!(
        open_events(&unknown_version),
        Err(SourceError::BadMagic { .. })
    ));
    assert!(matches!(
        open_events(dir.join("missing.aedat4")),
        Err(SourceError::Open { .. })
    ));
    std::fs::remove_dir_all(&dir).ok();
}

// ---- damaged input ----------------------------------------------------------------

/// Asserts the error points at `offset_bytes` and says so in its message.
fn assert_points_at(error: &SourceError, offset_bytes: u64) {
    assert_eq!(error.offset_bytes(), Some(offset_bytes), "{error}");
    assert!(
        error.to_string().contains(&offset_bytes.to_string()),
        "{error}"
    );
}

#[test]
fn truncated_files_name_the_field_offset() {
    let events = vec![ev(10, 1, 2, true), ev(20, 3, 4, false)];

    let aedat2 = aedat2_bytes(&events);
    let error = read_bytes(&aedat2[..aedat2.len() - 3], Format::Aedat2).unwrap_err();
    assert!(matches!(error, SourceError::Truncated { .. }), "{error}");
    assert_points_at(&error, aedat2.len() as u64 - 8);

    let aedat3 = aedat3_bytes(&events);
    let body_at = aedat3.len() as u64 - 16;
    let error = read_bytes(&aedat3[..aedat3.len() - 1], Format::Aedat3).unwrap_err();
    assert_points_at(&error, body_at);
    let error = read_bytes(&aedat3[..aedat3.len() - 20], Format::Aedat3).unwrap_err();
    assert!(error.to_string().contains("packet header"), "{error}");
    assert_points_at(&error, body_at - 28);

    let aedat4 = aedat4_bytes(&events, Compression::None);
    // Cut inside the first packet's body: its header ends where the IOHeader ends.
    let header_size = i32::from_le_bytes(aedat4[14..18].try_into().unwrap()) as u64;
    let body_at = 18 + header_size + 8;
    let error = read_bytes(&aedat4[..body_at as usize + 10], Format::Aedat4).unwrap_err();
    assert!(
        matches!(
            error,
            SourceError::Truncated {
                field: "event packet body",
                ..
            }
        ),
        "{error}"
    );
    assert_points_at(&error, body_at);
    let error = read_bytes(&aedat4[..30], Format::Aedat4).unwrap_err();
    assert_points_at(&error, 18);
}

#[test]
fn bad_magic_is_reported_at_byte_zero() {
    let aedat3 = aedat3_bytes(&[ev(1, 1, 1, true)]);
    for error in [
        Aedat4Reader::new(Cursor::new(aedat3.clone()))
            .err()
            .unwrap(),
        Aedat2Reader::new(Cursor::new(aedat3.clone()))
            .err()
            .unwrap(),
        Aedat3Reader::new(Cursor::new(b"#!AER".to_vec()))
            .err()
            .unwrap(),
    ] {
        assert!(
            matches!(
                error,
                SourceError::BadMagic {
                    offset_bytes: 0,
                    ..
                }
            ),
            "{error}"
        );
    }
}

#[test]
fn hostile_sizes_are_refused_before_allocating() {
    // AEDAT 4: header size of 2 GiB.
    let mut bytes = b"#!AER-DAT4.0\r\n".to_vec();
    bytes.extend_from_slice(&i32::MAX.to_le_bytes());
    let error = read_bytes(&bytes, Format::Aedat4).unwrap_err();
    assert!(
        matches!(
            error,
            SourceError::TooLarge {
                field: "IOHeader size",
                ..
            }
        ),
        "{error}"
    );
    assert_points_at(&error, 14);

    // AEDAT 4: a packet claiming 2 GiB, and one claiming a negative size.
    let good = aedat4_bytes(&[ev(1, 1, 1, true)], Compression::None);
    let header_size = i32::from_le_bytes(good[14..18].try_into().unwrap()) as usize;
    let size_at = 18 + header_size + 4;
    for (size, too_large) in [(i32::MAX, true), (-8, false)] {
        let mut bytes = good.clone();
        bytes[size_at..size_at + 4].copy_from_slice(&size.to_le_bytes());
        let error = read_bytes(&bytes, Format::Aedat4).unwrap_err();
        assert_eq!(
            matches!(error, SourceError::TooLarge { .. }),
            too_large,
            "{error}"
        );
        assert!(error.to_string().contains("packet size"), "{error}");
        assert_points_at(&error, size_at as u64);
    }

    // AEDAT 4: a packet size within the cap but past the end of a tiny file.
    let mut bytes = good.clone();
    bytes[size_at..size_at + 4].copy_from_slice(&(60_000_000i32).to_le_bytes());
    let error = read_bytes(&bytes, Format::Aedat4).unwrap_err();
    assert!(matches!(error, SourceError::Truncated { .. }), "{error}");

    // AEDAT 4: an event vector claiming 2^32 - 1 elements.
    let mut bytes = good.clone();
    let count_at = size_at + 4 + 28;
    bytes[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let error = read_bytes(&bytes, Format::Aedat4).unwrap_err();
    assert!(error.to_string().contains("overruns"), "{error}");
    assert_points_at(&error, count_at as u64);

    // AEDAT 3: capacity * size beyond 64 MiB.
    let mut bytes = aedat3_header();
    let packet_at = bytes.len() as u64;
    bytes.extend(aedat3_packet(1, 8, 0, i32::MAX, 0, &[]));
    let error = read_bytes(&bytes, Format::Aedat3).unwrap_err();
    assert!(matches!(error, SourceError::TooLarge { .. }), "{error}");
    assert_points_at(&error, packet_at + 4);

    // AEDAT 3: eventNumber above eventCapacity.
    let mut bytes = aedat3_header();
    bytes.extend(aedat3_packet(1, 8, 0, 1, 2, &[0; 8]));
    let error = read_bytes(&bytes, Format::Aedat3).unwrap_err();
    assert!(error.to_string().contains("eventNumber"), "{error}");
    assert_points_at(&error, packet_at + 20);

    // Text: an endless line.
    let mut text = b"0.1 1 2 1\n".to_vec();
    text.extend(std::iter::repeat_n(b'9', 100_000));
    let error = read_bytes(&text, Format::Text).unwrap_err();
    assert!(
        matches!(error, SourceError::TextLine { line: 2, .. }),
        "{error}"
    );
    assert_points_at(&error, 10);
}

#[test]
fn bad_text_lines_name_line_and_offset() {
    for (text, line, offset) in [
        ("0.1 1 2 1\n0.2 1 2\n", 2, 10),
        ("# header\n\n0.1 x 2 1\n", 3, 10),
        ("0.1 1 2 1\n0.2 1 2 7\n", 2, 10),
        ("0.1 1 70000 1\n", 1, 0),
        ("abc 1 2 1\n", 1, 0),
        ("0.1 1 2 1 5\n", 1, 0),
    ] {
        let error = read_bytes(text.as_bytes(), Format::Text).unwrap_err();
        assert!(
            matches!(error, SourceError::TextLine { line: l, .. } if l == line),
            "{text:?}: {error}"
        );
        assert_points_at(&error, offset);
        assert!(
            error
                .to_string()
                .starts_with(&format!("line {line}, byte {offset}")),
            "{error}"
        );
    }
}

#[test]
fn aedat2_pixels_off_the_sensor_are_errors() {
    let mut bytes = b"#!AER-DAT2.0\r\n".to_vec();
    bytes.extend_from_slice(&((200u32 << 22) | (5 << 12)).to_be_bytes());
    bytes.extend_from_slice(&1u32.to_be_bytes());
    let error = read_bytes(&bytes, Format::Aedat2).unwrap_err();
    assert_points_at(&error, 14);
}

#[test]
fn writers_refuse_what_their_format_cannot_hold() {
    let mut aedat2 = Aedat2Writer::new(Vec::new()).unwrap();
    assert!(aedat2.write_events(&[ev(-1, 0, 0, true)]).is_err());
    assert!(aedat2.write_events(&[ev(0, 240, 0, true)]).is_err());
    let mut aedat3 = Aedat3Writer::new(Vec::new()).unwrap();
    assert!(aedat3.write_events(&[ev(-1, 0, 0, true)]).is_err());
    let mut aedat4 = Aedat4Writer::new(Cursor::new(Vec::new()), Aedat4Config::default()).unwrap();
    assert!(aedat4.write_events(&[ev(0, 0, 180, true)]).is_err());
    aedat4.write_events(&[ev(10, 0, 0, true)]).unwrap();
    let error = aedat4.write_events(&[ev(9, 0, 0, true)]).unwrap_err();
    assert!(
        matches!(error, SourceError::Unrepresentable { .. }),
        "{error}"
    );
}

// ---- mutation corpus ----------------------------------------------------------------

/// Damages `bytes` one of several ways, biased towards the headers where sizes live.
fn mutate(rng: &mut Pcg64Mcg, bytes: &[u8]) -> Vec<u8> {
    let mut out = bytes.to_vec();
    for _ in 0..rng.random_range(1..4) {
        if out.is_empty() {
            break;
        }
        let hot_len = out.len().min(2048);
        let at = if rng.random_range(0..2) == 0 {
            rng.random_range(0..hot_len)
        } else {
            rng.random_range(0..out.len())
        };
        match rng.random_range(0..6) {
            0 => out[at] ^= 1 << rng.random_range(0..8),
            1 => out[at] = rng.random_range(0..=255),
            2 => out.truncate(at),
            3 => {
                let len = rng.random_range(1..8).min(out.len() - at);
                out.drain(at..at + len);
            }
            4 => {
                let value: u8 = rng.random_range(0..=255);
                out.insert(at, value);
            }
            _ => {
                // A 32-bit field set to an extreme.
                let extreme = [0u32, 1, 0x7FFF_FFFF, 0x8000_0000, u32::MAX][rng.random_range(0..5)];
                let end = (at + 4).min(out.len());
                out[at..end].copy_from_slice(&extreme.to_le_bytes()[..end - at]);
            }
        }
    }
    out
}

#[test]
fn mutated_and_truncated_files_never_panic() {
    let mut rng = Pcg64Mcg::seed_from_u64(0x5eed_f11e);
    let events: Vec<Event> = (0..200)
        .map(|i| {
            ev(
                1_000 + i * 97,
                (i * 31 % 240) as u16,
                (i * 17 % 180) as u16,
                i % 3 == 0,
            )
        })
        .collect();
    let mut corpus = vec![
        (aedat2_bytes(&events), Format::Aedat2),
        (aedat3_bytes(&events), Format::Aedat3),
        (text_bytes(&events), Format::Text),
    ];
    for compression in Compression::ALL {
        corpus.push((aedat4_bytes(&events, compression), Format::Aedat4));
    }
    let mut failures = 0;
    let mut mutations = 0;
    for (valid, format) in &corpus {
        // Every truncation point of the first 600 bytes, then random damage.
        for len in 0..valid.len().min(600) {
            let _ = read_bytes(&valid[..len], *format);
        }
        for _ in 0..2000 / corpus.len() + 1 {
            let damaged = mutate(&mut rng, valid);
            mutations += 1;
            if let Err(error) = read_bytes(&damaged, *format) {
                failures += 1;
                // Every error from bytes must point somewhere inside (or at the end of) them.
                if let Some(offset) = error.offset_bytes() {
                    assert!(
                        offset <= damaged.len() as u64,
                        "{error} for {} bytes",
                        damaged.len()
                    );
                }
            }
        }
    }
    assert!(mutations >= 2000);
    assert!(
        failures > mutations / 10,
        "damage was detected only {failures} times in {mutations}"
    );
}
