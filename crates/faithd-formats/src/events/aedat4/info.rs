//! The `infoNode` of an AEDAT 4 header: a small XML document in DV's configuration
//! tree format that lists the file's streams (`/outInfo/<id>/`), each with its
//! `typeIdentifier` (`EVTS` for polarity events) and its `info/sizeX`, `info/sizeY`.
//!
//! Only that subset of XML is understood: `<node name=".." path="..">`, `<attr key=".."
//! type="..">value</attr>` and the five predefined entities. Anything unexpected is
//! skipped rather than rejected, as the reader only needs the stream list.

use super::Compression;

/// One stream declared in the header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StreamInfo {
    pub id: i32,
    /// Four-letter flatbuffer identifier of the packets (`EVTS`, `FRME`, `IMUS`, ...).
    pub type_identifier: String,
    pub width_px: Option<u16>,
    pub height_px: Option<u16>,
    /// Camera or module that produced the stream (`info/source`).
    pub source: Option<String>,
}

/// Reads the stream list out of the `infoNode` XML.
pub fn parse_streams(xml: &str) -> Vec<StreamInfo> {
    let mut streams: Vec<StreamInfo> = Vec::new();
    for (path, key, value) in attributes(xml) {
        let Some(rest) = path.strip_prefix("/outInfo/") else {
            continue;
        };
        let (id_text, sub_path) = rest.split_once('/').unwrap_or((rest, ""));
        let Ok(id) = id_text.parse::<i32>() else {
            continue;
        };
        let index = match streams.iter().position(|s| s.id == id) {
            Some(index) => index,
            None => {
                streams.push(StreamInfo {
                    id,
                    type_identifier: String::new(),
                    width_px: None,
                    height_px: None,
                    source: None,
                });
                streams.len() - 1
            }
        };
        let stream = &mut streams[index];
        match (sub_path, key.as_str()) {
            ("", "typeIdentifier") => stream.type_identifier = value,
            ("info/", "sizeX") => stream.width_px = value.trim().parse().ok(),
            ("info/", "sizeY") => stream.height_px = value.trim().parse().ok(),
            ("info/", "source") => stream.source = Some(value),
            _ => {}
        }
    }
    streams.retain(|s| !s.type_identifier.is_empty());
    streams
}

/// Every `<attr>` with the path of the node that holds it.
fn attributes(xml: &str) -> Vec<(String, String, String)> {
    let mut found = Vec::new();
    let mut paths: Vec<String> = Vec::new();
    let mut rest = xml;
    while let Some(open) = rest.find('<') {
        rest = &rest[open + 1..];
        let Some(close) = rest.find('>') else { break };
        let tag = &rest[..close];
        rest = &rest[close + 1..];
        if tag.starts_with("/node") {
            paths.pop();
        } else if let Some(node) = tag.strip_prefix("node") {
            let parent = paths.last().map(String::as_str).unwrap_or("/");
            let path = attribute_value(node, "path").unwrap_or_else(|| {
                format!(
                    "{parent}{}/",
                    attribute_value(node, "name").unwrap_or_default()
                )
            });
            if !node.ends_with('/') {
                paths.push(path);
            }
        } else if let Some(attr) = tag.strip_prefix("attr") {
            let (Some(key), Some(end)) = (attribute_value(attr, "key"), rest.find("</attr>"))
            else {
                continue;
            };
            let value = unescape(&rest[..end]);
            rest = &rest[end + "</attr>".len()..];
            let path = paths.last().cloned().unwrap_or_else(|| "/".to_string());
            found.push((path, key, value));
        }
    }
    found
}

fn attribute_value(tag: &str, name: &str) -> Option<String> {
    let needle = format!("{name}=\"");
    let mut search = tag;
    loop {
        let at = search.find(&needle)?;
        let preceded_by_space = at == 0 || search.as_bytes()[at - 1].is_ascii_whitespace();
        let after = &search[at + needle.len()..];
        if preceded_by_space {
            let end = after.find('"')?;
            return Some(unescape(&after[..end]));
        }
        search = after;
    }
}

fn unescape(text: &str) -> String {
    text.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// The `infoNode` of a file with one event stream (id 0), laid out as DV writes it.
pub fn event_stream_xml(
    compression: Compression,
    width_px: u16,
    height_px: u16,
    source: &str,
) -> String {
    format!(
        "<dv version=\"2.0\">\n    <node name=\"outInfo\" path=\"/outInfo/\">\n        <node name=\"0\" path=\"/outInfo/0/\">\n            <attr key=\"compression\" type=\"string\">{}</attr>\n            <attr key=\"originalModuleName\" type=\"string\">faithd</attr>\n            <attr key=\"originalOutputName\" type=\"string\">events</attr>\n            <attr key=\"typeDescription\" type=\"string\">Array of events (polarity ON/OFF).</attr>\n            <attr key=\"typeIdentifier\" type=\"string\">EVTS</attr>\n            <node name=\"info\" path=\"/outInfo/0/info/\">\n                <attr key=\"sizeX\" type=\"int\">{width_px}</attr>\n                <attr key=\"sizeY\" type=\"int\">{height_px}</attr>\n                <attr key=\"source\" type=\"string\">{}</attr>\n            </node>\n        </node>\n    </node>\n</dv>\n",
        compression.name(),
        escape(source)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_xml_parses_back() {
        let xml = event_stream_xml(Compression::Zstd, 240, 180, "DVS <240> & co");
        let streams = parse_streams(&xml);
        assert_eq!(
            streams,
            vec![StreamInfo {
                id: 0,
                type_identifier: "EVTS".to_string(),
                width_px: Some(240),
                height_px: Some(180),
                source: Some("DVS <240> & co".to_string()),
            }]
        );
    }

    #[test]
    fn several_streams_keep_their_types() {
        let xml = r#"<dv version="2.0"><node name="outInfo" path="/outInfo/">
            <node name="1" path="/outInfo/1/"><attr key="typeIdentifier" type="string">FRME</attr></node>
            <node name="3" path="/outInfo/3/"><attr key="typeIdentifier" type="string">EVTS</attr>
            <node name="info" path="/outInfo/3/info/"><attr key="sizeX" type="int">346</attr></node></node>
            </node></dv>"#;
        let streams = parse_streams(xml);
        assert_eq!(streams.len(), 2);
        assert_eq!(streams[0].type_identifier, "FRME");
        assert_eq!((streams[1].id, streams[1].width_px), (3, Some(346)));
    }

    #[test]
    fn garbage_gives_no_streams_and_no_panic() {
        for xml in [
            "",
            "<",
            "<attr key=\"x\">",
            "<node path=\"/outInfo/9/\"><attr key=\"typeIdentifier\">",
            "</node></node>",
        ] {
            let _ = parse_streams(xml);
        }
    }
}
