//! The renderer's output is pinned bit for bit: the same events (time, pixel,
//! polarity, order) and the same depth and log-intensity maps as the renderer that produced the
//! published `faithd bench foe` figures, so that speeding it up cannot move them.
//!
//! The expected hashes were computed on the original renderer (commit 2a8cfbd, before
//! any optimisation) and written here; a change of any f64 operation's order in a
//! render shows up as a different hash.

use faithd_core::camera::{CameraIntrinsics, Mounting};
use faithd_core::event::Event;
use faithd_sim::world::{DvsConfig, EventCamera, SceneKind, Trajectory};

/// FNV-1a, 64 bits: stable across Rust releases, unlike `DefaultHasher`.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    fn event(&mut self, e: &Event) {
        self.bytes(&e.t_us.to_le_bytes());
        self.bytes(&e.x_px.to_le_bytes());
        self.bytes(&e.y_px.to_le_bytes());
        self.bytes(&[e.polarity as u8]);
    }
}

/// What a flight produced: event count, hash of the events, hash of every render's
/// depth and log-intensity maps.
fn fly(kind: SceneKind, trajectory: &Trajectory, renders: i64) -> (usize, u64, u64) {
    let scene = kind.build(11);
    let mut camera = EventCamera::new(
        CameraIntrinsics::dvs240(),
        Mounting::forward(),
        DvsConfig::default(),
        5,
    );
    let mut events = Vec::new();
    let mut image = Fnv::new();
    for k in 0..renders {
        let t_us = k * 1000;
        camera.advance(
            &scene,
            &trajectory.state(t_us as f64 * 1e-6),
            t_us,
            &mut events,
        );
        for d in camera.depth_m().iter().chain(camera.log_intensity()) {
            image.bytes(&d.to_bits().to_le_bytes());
        }
    }
    let mut hash = Fnv::new();
    for e in &events {
        hash.event(e);
    }
    (events.len(), hash.0, image.0)
}

/// Three flights per scene: from the benchmark's start line, swaying and rotating
/// from mid-room, and close to what lies ahead (many events per render).
fn flights() -> [(&'static str, Trajectory); 3] {
    let far = Trajectory::straight([-4.0, 0.2, -1.2], 3.0, 10.0, 2.0);
    let mut rotating = Trajectory::straight([-1.0, -0.3, -1.1], -5.0, -20.0, 1.5);
    rotating.sway_m_s = 0.6;
    rotating.sway_hz = 1.2;
    rotating.yaw_amp_deg = 3.0;
    rotating.yaw_hz = 0.8;
    rotating.pitch_amp_deg = 1.5;
    rotating.pitch_hz = 0.7;
    let near = Trajectory::straight([1.6, 0.05, -1.3], 0.0, 0.0, 2.5);
    [("far", far), ("rotating", rotating), ("near", near)]
}

#[test]
fn renders_are_bit_identical_to_the_original_renderer() {
    let mut got = Vec::new();
    for kind in SceneKind::ALL {
        for (name, trajectory) in flights() {
            let (count, events, images) = fly(kind, &trajectory, 30);
            got.push(format!(
                "(\"{}\", \"{name}\", {count}, {events:#018x}, {images:#018x}),",
                kind.name()
            ));
        }
    }
    let got = got.join("\n");
    let expected = EXPECTED
        .iter()
        .map(|(scene, flight, count, events, images)| {
            format!("(\"{scene}\", \"{flight}\", {count}, {events:#018x}, {images:#018x}),")
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(got, expected);
}

/// (scene, flight, events, hash of the events, hash of the images), from the
/// original renderer.
const EXPECTED: &[(&str, &str, usize, u64, u64)] = &[
    ("arena", "far", 6112, 0xb45b459543c77052, 0x17f9ffcf67d825c7),
    (
        "arena",
        "rotating",
        13383,
        0x0c202134a8322b89,
        0xaa4bc8e0a45407a1,
    ),
    (
        "arena",
        "near",
        14027,
        0x251a1d013d7ff403,
        0x8739617aaf1847e8,
    ),
    (
        "kitchen",
        "far",
        4217,
        0x06050371bffa8dd5,
        0x659fd603659c9f47,
    ),
    (
        "kitchen",
        "rotating",
        10191,
        0x11ddeafb0db08107,
        0xec40f5341e034e6c,
    ),
    (
        "kitchen",
        "near",
        8942,
        0x3d7e112bf52406ff,
        0xc364e019d2cece84,
    ),
    (
        "shelves",
        "far",
        2569,
        0x709a84cbd632682c,
        0x46e371ab7b32e503,
    ),
    (
        "shelves",
        "rotating",
        6080,
        0xb2b778946fb8c1c7,
        0xb17d9ace54985b6d,
    ),
    (
        "shelves",
        "near",
        5171,
        0xe5c549d673531c61,
        0x728d7e82ba5ecbfe,
    ),
    (
        "warehouse",
        "far",
        224,
        0xe8550a818aee8fdd,
        0x99fa97dcaa593721,
    ),
    (
        "warehouse",
        "rotating",
        212,
        0x5c5597086c4bc0b0,
        0x1656522f982eec87,
    ),
    (
        "warehouse",
        "near",
        2778,
        0xa9cb059b0af5ff7c,
        0x09b63e0cab839ab8,
    ),
];
