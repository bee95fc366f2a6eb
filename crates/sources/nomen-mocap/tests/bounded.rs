//! Motion-capture files past their limits: an endless line, an endless file and a BVH
//! hierarchy that never reaches `MOTION` are refused with the limit named, after reading no
//! more than the limit (each test would never end, or run out of memory, without the bound).

use nomen_mocap::bvh::MAX_BVH_HIERARCHY_BYTES;
use nomen_mocap::{MAX_MOCAP_BYTES, MocapError, parse_bvh, read_mocap_stream};
use std::io::Read;

/// `pattern` repeated for ever.
struct Endless(&'static [u8], usize);

impl Read for Endless {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        for b in buf.iter_mut() {
            *b = self.0[self.1 % self.0.len()];
            self.1 += 1;
        }
        Ok(buf.len())
    }
}

#[test]
fn an_endless_frame_line_is_refused_at_the_line_limit() {
    let head = "HIERARCHY\nROOT Hips\n{\n";
    let input = head.as_bytes().chain(Endless(b"0.0 ", 0));
    let err = read_mocap_stream(input, "walk.bvh").unwrap_err();
    assert_eq!(
        err.to_string(),
        "line 4 of walk.bvh is longer than 1 MiB, the longest line a motion-capture file may have"
    );
}

#[test]
fn an_endless_file_of_short_lines_is_refused_at_the_file_limit() {
    let err = read_mocap_stream(Endless(b"1 2 3\n", 0), "take.amc").unwrap_err();
    assert!(matches!(
        err,
        MocapError::Limit(nomen_core::CoreError::InputTooLarge { max_input_bytes, .. })
            if max_input_bytes == MAX_MOCAP_BYTES
    ));
    assert_eq!(
        err.to_string(),
        "take.amc holds more than 64 MiB, the most a motion-capture file may have"
    );
}

#[test]
fn a_hierarchy_without_motion_is_refused_at_its_limit() {
    // Short lines of joints past the hierarchy limit, no MOTION: refused before its tokens
    // are collected.
    let line = "JOINT j { OFFSET 0 0 0 CHANNELS 0\n";
    let text = format!(
        "HIERARCHY\nROOT Hips\n{}",
        line.repeat(MAX_BVH_HIERARCHY_BYTES / line.len() + 1)
    );
    let err = parse_bvh(&text, "deep.bvh").unwrap_err();
    let MocapError::HierarchyTooLong { line, .. } = &err else {
        panic!("{err}");
    };
    // The first line that ends past the limit.
    let expected_line =
        2 + (MAX_BVH_HIERARCHY_BYTES - "HIERARCHY\nROOT Hips\n".len()) / line_len() + 1;
    assert_eq!(*line, expected_line);
    assert_eq!(
        err.to_string(),
        format!(
            "deep.bvh:{line}: the hierarchy runs past 4 MiB, the longest a BVH hierarchy may \
             have, without a MOTION line"
        )
    );
}

fn line_len() -> usize {
    "JOINT j { OFFSET 0 0 0 CHANNELS 0\n".len()
}
