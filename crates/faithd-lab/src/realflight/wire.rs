//! The RealFlight ("FlightAxis") SOAP exchange as iNav 9.1 SITL speaks it, from the
//! server's side. Written from iNav's source (src/main/target/SITL/sim/soap_client.c
//! and realFlight.c; `../shared/inav.md`):
//!
//! - one HTTP POST per call on a fresh TCP connection, `SOAPAction: "<Action>"`, an
//!   exact Content-Length and `Connection: close` (soap_client.c:398-450);
//! - iNav reads the answer until the server closes the connection and ignores its
//!   Content-Length (soap_client.c:162-204), needs the status line and a `...Body`
//!   element (soap_client.c:206-212, 285-351);
//! - it finds every field by searching for `m-NAME` and reading the number one
//!   character after it (realFlight.c:136-147), so each field is written
//!   `<m-NAME>number</m-NAME>` with no attributes, and the transmitter's channels
//!   need the exact array tag followed by 12 tight `<item>`s (realFlight.c:188-212);
//! - ExchangeData carries iNav's 12 output channels, each (us - 1000) / 1000
//!   (realFlight.c:231-249, simHelper.h:30).
//!
//! Frames as iNav reads them (realFlight.c:320-372): position X north and Y minus
//! east; velocity V north, U minus east, W down; inclination nose up; azimuth
//! 270 degrees minus the heading; yaw rate positive nose left; accelerations the body's
//! specific force (FRD, -g on z at rest).
//!
//! Pure: bytes in, bytes out. Every malformed request is an error naming the byte
//! offset; nothing here panics on what arrives from the socket.

use std::io::BufRead;

use faithd_sim::world::quad_x::QuadX;

/// iNav's output channels in one exchange.
pub const CHANNELS: usize = 12;
/// A request's headers beyond this are not iNav's.
const MAX_HEADER_BYTES: usize = 16 * 1024;
/// iNav's ExchangeData body is under 1 KiB.
const MAX_BODY_BYTES: usize = 64 * 1024;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WireError {
    #[error("connection closed after {0} bytes, inside a request")]
    Truncated(usize),
    #[error("request headers longer than {MAX_HEADER_BYTES} bytes")]
    HeadersTooLong,
    #[error("byte {offset}: {what}")]
    Malformed { offset: usize, what: String },
    #[error("reading the request: {0}")]
    Io(String),
}

fn malformed(offset: usize, what: impl Into<String>) -> WireError {
    WireError::Malformed {
        offset,
        what: what.into(),
    }
}

/// What iNav asked for.
#[derive(Clone, Debug, PartialEq)]
pub enum Call {
    RestoreOriginalControllerDevice,
    InjectUAVControllerInterface,
    /// iNav's outputs, each 0..1 as iNav scaled them (the chanmap decides which is a
    /// motor: `M01-01,...` puts motor 1 on channel 1).
    ExchangeData {
        channels: [f64; CHANNELS],
    },
}

/// Reads one request: headers up to the blank line, then Content-Length bytes.
pub fn read_call(reader: &mut impl BufRead) -> Result<Call, WireError> {
    let mut head = Vec::new();
    loop {
        let before = head.len();
        let n = reader
            .read_until(b'\n', &mut head)
            .map_err(|e| WireError::Io(e.to_string()))?;
        if n == 0 {
            return Err(WireError::Truncated(before));
        }
        if head.len() > MAX_HEADER_BYTES {
            return Err(WireError::HeadersTooLong);
        }
        if head.ends_with(b"\r\n\r\n") || head.ends_with(b"\n\n") {
            break;
        }
    }
    let head_text = std::str::from_utf8(&head)
        .map_err(|e| malformed(e.valid_up_to(), "headers are not UTF-8"))?;
    let mut lines = head_text.lines();
    let request_line = lines.next().unwrap_or_default();
    if !request_line.starts_with("POST ") {
        return Err(malformed(0, format!("not a POST: {request_line:?}")));
    }
    let (mut action, mut length) = (None, None);
    let mut offset = request_line.len() + 2;
    for line in lines {
        if let Some((name, value)) = line.split_once(':') {
            let value = value.trim();
            if name.eq_ignore_ascii_case("SOAPAction") {
                action = Some(value.trim_matches('"').to_owned());
            } else if name.eq_ignore_ascii_case("Content-Length") {
                length = Some(value.parse::<usize>().map_err(|_| {
                    malformed(
                        offset,
                        format!("Content-Length {value:?} is not a byte count"),
                    )
                })?);
            }
        }
        offset += line.len() + 2;
    }
    let action = action.ok_or_else(|| malformed(head.len(), "no SOAPAction header"))?;
    let length = length.ok_or_else(|| malformed(head.len(), "no Content-Length header"))?;
    if length > MAX_BODY_BYTES {
        return Err(malformed(head.len(), format!("a body of {length} bytes")));
    }
    let mut body = vec![0; length];
    std::io::Read::read_exact(reader, &mut body).map_err(|_| WireError::Truncated(head.len()))?;
    let body = String::from_utf8_lossy(&body);
    match action.as_str() {
        "RestoreOriginalControllerDevice" => Ok(Call::RestoreOriginalControllerDevice),
        "InjectUAVControllerInterface" => Ok(Call::InjectUAVControllerInterface),
        "ExchangeData" => parse_channels(&body)
            .map(|channels| Call::ExchangeData { channels })
            .map_err(|e| match e {
                WireError::Malformed { offset, what } => malformed(head.len() + offset, what),
                other => other,
            }),
        other => Err(malformed(0, format!("unknown SOAPAction {other:?}"))),
    }
}

/// The 12 `<item>`s of `<m-channelValues-0to1>` in an ExchangeData body.
fn parse_channels(body: &str) -> Result<[f64; CHANNELS], WireError> {
    const OPEN: &str = "<m-channelValues-0to1>";
    let start = body
        .find(OPEN)
        .ok_or_else(|| malformed(0, "ExchangeData without <m-channelValues-0to1>"))?;
    let mut at = start + OPEN.len();
    let mut channels = [0.0; CHANNELS];
    for (i, channel) in channels.iter_mut().enumerate() {
        let rest = &body[at..];
        let Some(value) = rest.strip_prefix("<item>") else {
            return Err(malformed(at, format!("channel {} is not an <item>", i + 1)));
        };
        let end = value
            .find("</item>")
            .ok_or_else(|| malformed(at, format!("channel {} has no </item>", i + 1)))?;
        let text = &value[..end];
        *channel = text
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| malformed(at + 6, format!("channel {} is {text:?}", i + 1)))?;
        at += "<item>".len() + end + "</item>".len();
    }
    Ok(channels)
}

/// What the server tells iNav besides the vehicle's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extras {
    /// Height of the ground above sea level, metres (iNav's GPS altitude and baro).
    pub ground_asl_m: f64,
    pub battery_v: f64,
    pub current_a: f64,
}

impl Default for Extras {
    fn default() -> Self {
        Self {
            ground_asl_m: 100.0,
            battery_v: 16.0,
            current_a: 0.0,
        }
    }
}

/// The fields of an ExchangeData answer for `quad`, in iNav's frames.
pub fn state_fields(quad: &QuadX, extras: &Extras) -> Vec<(&'static str, f64)> {
    let (roll, pitch, heading) = quad.euler_rad();
    let p = quad.position_m;
    let v = quad.velocity_m_s;
    let rates = quad.body_rates_rad_s.map(f64::to_degrees);
    let f = quad.specific_force_m_s2;
    let azimuth_deg = (270.0 - heading.to_degrees()).rem_euclid(360.0);
    let horizontal_m_s = v.x.hypot(v.y);
    vec![
        ("m-airspeed-MPS", v.norm()),
        ("m-altitudeASL-MTR", extras.ground_asl_m - p.z),
        ("m-altitudeAGL-MTR", -p.z),
        ("m-groundspeed-MPS", horizontal_m_s),
        ("m-rollRate-DEGpSEC", rates.x),
        ("m-pitchRate-DEGpSEC", rates.y),
        ("m-yawRate-DEGpSEC", -rates.z),
        ("m-roll-DEG", roll.to_degrees()),
        ("m-inclination-DEG", pitch.to_degrees()),
        ("m-azimuth-DEG", azimuth_deg),
        ("m-aircraftPositionX-MTR", p.x),
        ("m-aircraftPositionY-MTR", -p.y),
        ("m-velocityWorldU-MPS", -v.y),
        ("m-velocityWorldV-MPS", v.x),
        ("m-velocityWorldW-MPS", v.z),
        ("m-accelerationBodyAX-MPS2", f.x),
        ("m-accelerationBodyAY-MPS2", f.y),
        ("m-accelerationBodyAZ-MPS2", f.z),
        ("m-batteryVoltage-VOLTS", extras.battery_v),
        ("m-batteryCurrentDraw-AMPS", extras.current_a),
    ]
}

/// The whole HTTP answer to an ExchangeData call. The transmitter's 12 channels are
/// sent at mid-stick: iNav reads them only with `receiver_type = SIM (SITL)`, and the
/// pilot here flies on a real receiver protocol.
pub fn exchange_reply(quad: &QuadX, extras: &Extras) -> Vec<u8> {
    let mut body = String::from("<ExchangeDataResponse><a>");
    for (name, value) in state_fields(quad, extras) {
        body += &format!("<{name}>{value:.6}</{name}>");
    }
    body += "<m-currentAircraftStatus>CAS-FLYING</m-currentAircraftStatus>";
    body +=
        "<m-channelValues-0to1 xsi:type=\"SOAP-ENC:Array\" SOAP-ENC:arrayType=\"xsd:double[12]\">";
    for _ in 0..CHANNELS {
        body += "<item>0.5</item>";
    }
    body += "</m-channelValues-0to1></a></ExchangeDataResponse>";
    reply(&body)
}

/// The answer to RestoreOriginalControllerDevice and InjectUAVControllerInterface.
pub fn ack_reply(call: &Call) -> Vec<u8> {
    let name = match call {
        Call::RestoreOriginalControllerDevice => "RestoreOriginalControllerDeviceResponse",
        Call::InjectUAVControllerInterface => "InjectUAVControllerInterfaceResponse",
        Call::ExchangeData { .. } => "ExchangeDataResponse",
    };
    reply(&format!("<{name}/>"))
}

/// A SOAP fault, for a request this server cannot read (iNav counts it as failed).
pub fn fault_reply(error: &WireError) -> Vec<u8> {
    let text = error.to_string().replace('&', "&amp;").replace('<', "&lt;");
    http(
        "500 Internal Server Error",
        &envelope(&format!(
            "<soap:Fault><faultstring>{text}</faultstring></soap:Fault>"
        )),
    )
}

fn reply(body: &str) -> Vec<u8> {
    http("200 OK", &envelope(body))
}

fn envelope(body: &str) -> String {
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?><soap:Envelope \
         xmlns:soap=\"http://schemas.xmlsoap.org/soap/envelope/\" \
         xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" \
         xmlns:SOAP-ENC=\"http://schemas.xmlsoap.org/soap/encoding/\"><soap:Body>{body}</soap:Body></soap:Envelope>"
    )
}

fn http(status: &str, body: &str) -> Vec<u8> {
    format!(
        "HTTP/1.1 {status}\r\nContent-Type: text/xml; charset=utf-8\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
    .into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use faithd_sim::world::quad_x::{G_M_S2, QuadXConfig};
    use nalgebra::{Rotation3, Vector3};

    /// A request as iNav writes it (soap_client.c:398-450, realFlight.c:242-249).
    fn inav_request(action: &str, body: &str) -> Vec<u8> {
        let envelope = format!(
            "<?xml version=\"1.0\" encoding=\"utf-8\"?><soap:Envelope xmlns:soap=\"http://schemas.xmlsoap.org/soap/envelope/\"><soap:Body>{body}</soap:Body></soap:Envelope>"
        );
        format!(
            "POST / HTTP/1.1\r\nHost: 127.0.0.1:18083\r\nContent-Type: text/xml; charset=utf-8\r\nSOAPAction: \"{action}\"\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{envelope}",
            envelope.len()
        )
        .into_bytes()
    }

    fn exchange_body(values: &[f64; CHANNELS]) -> String {
        let items: String = values
            .iter()
            .map(|v| format!("<item>{v:.4}</item>"))
            .collect();
        format!(
            "<ExchangeData><pControlInputs><m-selectedChannels>4095</m-selectedChannels><m-channelValues-0to1>{items}</m-channelValues-0to1></pControlInputs></ExchangeData>"
        )
    }

    #[test]
    fn inavs_three_calls_are_read() {
        let restore = inav_request(
            "RestoreOriginalControllerDevice",
            "<RestoreOriginalControllerDevice><a>1</a><b>2</b></RestoreOriginalControllerDevice>",
        );
        assert_eq!(
            read_call(&mut &restore[..]),
            Ok(Call::RestoreOriginalControllerDevice)
        );
        let mut values = [0.0; CHANNELS];
        values[..4].copy_from_slice(&[0.08, 0.5, 0.5125, 1.0]);
        let exchange = inav_request("ExchangeData", &exchange_body(&values));
        assert_eq!(
            read_call(&mut &exchange[..]),
            Ok(Call::ExchangeData { channels: values })
        );
    }

    #[test]
    fn a_broken_request_names_its_byte() {
        let mut values = [0.0; CHANNELS];
        values[2] = 0.5;
        let body = exchange_body(&values).replace("<item>0.5000</item>", "<item>half</item>");
        let request = inav_request("ExchangeData", &body);
        let at = String::from_utf8_lossy(&request).find("half").unwrap();
        match read_call(&mut &request[..]) {
            Err(WireError::Malformed { offset, what }) => {
                assert!(what.contains("channel 3"), "{what}");
                assert_eq!(offset, at, "the offset of the bad value in the request");
            }
            other => panic!("{other:?}"),
        }
        let cut = &inav_request("ExchangeData", &exchange_body(&values))[..40];
        assert!(matches!(
            read_call(&mut &cut[..]),
            Err(WireError::Truncated(_))
        ));
    }

    /// Reads a field the way iNav does (realFlight.c:136-147): the text after
    /// `m-NAME` and one more character, as a number.
    fn inav_reads(reply: &[u8], name: &str) -> f64 {
        let text = String::from_utf8_lossy(reply);
        let at = text.find(name).unwrap() + name.len() + 1;
        let rest = &text[at..];
        rest[..rest.find('<').unwrap()].parse().unwrap()
    }

    #[test]
    fn the_answer_is_in_inavs_frames() {
        let mut quad = QuadX::on_ground(QuadXConfig::default(), Vector3::new(2.0, 3.0, 0.0), 0.0);
        quad.position_m.z = -5.0;
        quad.velocity_m_s = Vector3::new(1.0, 2.0, -0.5);
        // 10 degrees right wing down, 5 nose up, heading 30 east of north.
        quad.attitude =
            Rotation3::from_euler_angles(10f64.to_radians(), 5f64.to_radians(), 30f64.to_radians());
        quad.body_rates_rad_s = Vector3::new(0.1, 0.2, 0.3);
        let reply = exchange_reply(&quad, &Extras::default());
        let close = |name: &str, want: f64| {
            let got = inav_reads(&reply, name);
            assert!((got - want).abs() < 1e-4, "{name}: {got} vs {want}");
        };
        close("m-roll-DEG", 10.0);
        close("m-inclination-DEG", 5.0);
        close("m-azimuth-DEG", 240.0);
        close("m-aircraftPositionX-MTR", 2.0);
        close("m-aircraftPositionY-MTR", -3.0);
        close("m-velocityWorldV-MPS", 1.0);
        close("m-velocityWorldU-MPS", -2.0);
        close("m-velocityWorldW-MPS", -0.5);
        close("m-altitudeAGL-MTR", 5.0);
        close("m-altitudeASL-MTR", 105.0);
        close("m-rollRate-DEGpSEC", 0.1f64.to_degrees());
        close("m-yawRate-DEGpSEC", -(0.3f64.to_degrees()));
        let text = String::from_utf8_lossy(&reply);
        assert!(text.starts_with("HTTP/1.1 200 OK\r\n"));
        assert!(text.contains("<m-channelValues-0to1 xsi:type=\"SOAP-ENC:Array\" SOAP-ENC:arrayType=\"xsd:double[12]\"><item>0.5</item><item>"));
        let at_rest = QuadX::on_ground(QuadXConfig::default(), Vector3::zeros(), 0.0);
        let reply = exchange_reply(&at_rest, &Extras::default());
        assert!((inav_reads(&reply, "m-accelerationBodyAZ-MPS2") + G_M_S2).abs() < 1e-5);
    }
}
