//! A sans-IO BVH parser: text in, [`Bvh`] out.
//!
//! Grammar accepted (whitespace-separated tokens; line breaks only matter in `MOTION`):
//!
//! ```text
//! HIERARCHY
//! ROOT <name> { OFFSET x y z  CHANNELS n <n names>  (JOINT <name> { ... } | End Site { OFFSET x y z })* }
//! MOTION
//! Frames: <n>
//! Frame Time: <seconds>
//! <one line per frame: one value per channel, in hierarchy order>
//! ```
//!
//! Channels may come in any order and any number per joint; each joint's `CHANNELS` line is read
//! as written. A `JOINT` without `CHANNELS` has none. One `ROOT` per file.

use crate::error::{MocapError, Result};
use nalgebra::Vector3;

/// Deepest joint nesting accepted (real skeletons nest about 10 deep); guards the recursion.
const MAX_DEPTH: usize = 256;

/// Most joint poses (joints and end sites × frames) a file may hold: 2^24, about 1 GB once
/// converted (CMU's 38-node skeletons: 440,000 frames, two hours at 60 Hz). A file of a few
/// megabytes with thousands of nodes and frames would otherwise take gigabytes.
pub const MAX_JOINT_POSES: usize = 1 << 24;

/// The longest hierarchy a BVH file may have (the bytes before its `MOTION` line), bytes:
/// 4 MiB. CMU's 38-node hierarchies are about 10 kB; a hierarchy's tokens are held while it is
/// parsed (24 bytes each), so a file whose `MOTION` never comes is refused here.
pub const MAX_BVH_HIERARCHY_BYTES: usize = 4 << 20;

/// Largest capacity reserved for the frame values before they are read, values (32 MB): the
/// header's frame and channel counts are not trusted with more.
const MAX_RESERVED_VALUES: usize = 1 << 22;

/// One BVH channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Translation along the parent's X axis, file units.
    Xposition,
    /// Translation along the parent's Y axis, file units.
    Yposition,
    /// Translation along the parent's Z axis, file units.
    Zposition,
    /// Rotation about the joint's X axis, degrees.
    Xrotation,
    /// Rotation about the joint's Y axis, degrees.
    Yrotation,
    /// Rotation about the joint's Z axis, degrees.
    Zrotation,
}

impl Channel {
    /// Parses a channel name as written in BVH files (case-sensitive, e.g. `Zrotation`).
    pub fn from_name(name: &str) -> Option<Channel> {
        Some(match name {
            "Xposition" => Channel::Xposition,
            "Yposition" => Channel::Yposition,
            "Zposition" => Channel::Zposition,
            "Xrotation" => Channel::Xrotation,
            "Yrotation" => Channel::Yrotation,
            "Zrotation" => Channel::Zrotation,
            _ => return None,
        })
    }

    /// The axis index (0 = X, 1 = Y, 2 = Z).
    pub fn axis(self) -> usize {
        match self {
            Channel::Xposition | Channel::Xrotation => 0,
            Channel::Yposition | Channel::Yrotation => 1,
            Channel::Zposition | Channel::Zrotation => 2,
        }
    }

    /// Whether this is a rotation channel (degrees) rather than a position channel.
    pub fn is_rotation(self) -> bool {
        matches!(
            self,
            Channel::Xrotation | Channel::Yrotation | Channel::Zrotation
        )
    }
}

/// One node of the hierarchy: a `ROOT`, a `JOINT` or an `End Site`.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhNode {
    /// The joint name as written. End Sites are named `<parent>_end` (`LeftToeBase_end`).
    pub name: String,
    /// Index of the parent node in [`Bvh::nodes`]; `None` for the root. Parents always come
    /// before their children.
    pub parent: Option<usize>,
    /// `OFFSET`: the node's origin in its parent's frame, file units.
    pub offset: Vector3<f64>,
    /// Channels in the order written (empty for End Sites).
    pub channels: Vec<Channel>,
    /// Index of this node's first channel in a frame's values.
    pub first_channel: usize,
    /// Whether this node is an `End Site` (a leaf point with no channels of its own).
    pub is_end_site: bool,
    /// Line of the `ROOT`/`JOINT`/`End` keyword.
    pub line: usize,
}

/// A parsed BVH file: hierarchy plus motion values, in file units and the file's axes (Y up).
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// Source name used in messages (usually the file name).
    pub source: String,
    /// Hierarchy nodes in file order; `nodes[0]` is the root.
    pub nodes: Vec<BvhNode>,
    /// Total number of channels, i.e. values per frame.
    pub num_channels: usize,
    /// `Frame Time:` as written, seconds.
    pub frame_time_s: f64,
    /// Number of frames.
    pub num_frames: usize,
    /// Motion values, frame-major: `values[frame * num_channels + channel]`.
    pub values: Vec<f64>,
}

impl Bvh {
    /// The values of one frame, or `None` past the end.
    pub fn frame(&self, frame: usize) -> Option<&[f64]> {
        let start = frame.checked_mul(self.num_channels)?;
        self.values
            .get(start..start.checked_add(self.num_channels)?)
    }

    /// Index of the node called `name` (exact match).
    pub fn node_index(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    /// The rate the header states, `1 / frame_time_s`, Hz.
    pub fn header_rate_hz(&self) -> f64 {
        1.0 / self.frame_time_s
    }
}

/// Parses BVH text. `source` names the text in error messages (`walk.bvh:12: ...`).
pub fn parse_bvh(text: &str, source: &str) -> Result<Bvh> {
    // A byte-order mark (some Windows editors write one) is not part of the first keyword.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let num_lines = text.lines().count();
    // The hierarchy's lines, up to MOTION, within MAX_BVH_HIERARCHY_BYTES: its tokens are
    // kept (24 bytes each), the frames' are not.
    let mut motion_line = None;
    let mut header_bytes = 0;
    for (i, l) in text.lines().enumerate() {
        if l.split_whitespace().next() == Some("MOTION") {
            motion_line = Some(i);
            break;
        }
        header_bytes += l.len() + 1;
        if header_bytes > MAX_BVH_HIERARCHY_BYTES {
            return Err(MocapError::HierarchyTooLong {
                file: source.to_owned(),
                line: i + 1,
                max_bytes: MAX_BVH_HIERARCHY_BYTES,
            });
        }
    }
    let header_end = motion_line.unwrap_or(num_lines);
    let tokens: Vec<(usize, &str)> = text
        .lines()
        .take(header_end)
        .enumerate()
        .flat_map(|(i, l)| l.split_whitespace().map(move |t| (i + 1, t)))
        .collect();
    let mut hp = HierarchyParser {
        file: source,
        tokens,
        pos: 0,
        // Where the hierarchy ends: the MOTION line, or the last line of the text.
        end_line: motion_line.map_or(num_lines.max(1), |i| i + 1),
        nodes: Vec::new(),
        num_channels: 0,
    };
    hp.parse()?;
    let Some(motion_line) = motion_line else {
        return Err(MocapError::UnexpectedEof {
            file: source.to_owned(),
            line: num_lines.max(1),
            expected: "MOTION".to_owned(),
        });
    };
    let (num_frames, frame_time_s, values) = parse_motion(
        text,
        num_lines,
        motion_line + 1,
        (hp.num_channels, hp.nodes.len()),
        source,
    )?;
    Ok(Bvh {
        source: source.to_owned(),
        nodes: hp.nodes,
        num_channels: hp.num_channels,
        frame_time_s,
        num_frames,
        values,
    })
}

struct HierarchyParser<'a> {
    file: &'a str,
    tokens: Vec<(usize, &'a str)>,
    pos: usize,
    end_line: usize,
    nodes: Vec<BvhNode>,
    num_channels: usize,
}

impl<'a> HierarchyParser<'a> {
    fn peek(&self) -> Option<(usize, &'a str)> {
        self.tokens.get(self.pos).copied()
    }

    fn next(&mut self, expected: &str) -> Result<(usize, &'a str)> {
        let tok = self.peek().ok_or_else(|| MocapError::UnexpectedEof {
            file: self.file.to_owned(),
            line: self.end_line,
            expected: expected.to_owned(),
        })?;
        self.pos += 1;
        Ok(tok)
    }

    fn expect(&mut self, keyword: &str) -> Result<usize> {
        let (line, tok) = self.next(&format!("'{keyword}'"))?;
        if tok == keyword {
            Ok(line)
        } else {
            Err(self.unexpected(line, &format!("'{keyword}'"), tok))
        }
    }

    fn unexpected(&self, line: usize, expected: &str, found: &str) -> MocapError {
        MocapError::Unexpected {
            file: self.file.to_owned(),
            line,
            expected: expected.to_owned(),
            found: found.to_owned(),
        }
    }

    fn number(&mut self, what: &str) -> Result<f64> {
        let (line, tok) = self.next(what)?;
        parse_finite(tok, self.file, line, what)
    }

    fn parse(&mut self) -> Result<()> {
        // The first token says whether this is a BVH file at all; another file's is not quoted.
        let (line, first) = self.next("'HIERARCHY'")?;
        if first != "HIERARCHY" {
            return Err(MocapError::NotOfKind {
                file: self.file.to_owned(),
                line,
                kind: "a BVH file",
                expected: "'HIERARCHY'",
            });
        }
        let line = self.expect("ROOT")?;
        let (_, name) = self.next("the root joint's name")?;
        self.joint(name.to_owned(), None, line, false, 0)?;
        if let Some((line, tok)) = self.peek() {
            return Err(match tok {
                "}" => MocapError::UnbalancedBraces {
                    file: self.file.to_owned(),
                    line,
                    detail: "'}' without a matching '{'".to_owned(),
                },
                "ROOT" => self.unexpected(line, "'MOTION' (one ROOT per file)", tok),
                _ => self.unexpected(line, "'MOTION'", tok),
            });
        }
        Ok(())
    }

    /// Parses `{ OFFSET ... [CHANNELS ...] children }` after a joint's name.
    fn joint(
        &mut self,
        name: String,
        parent: Option<usize>,
        line: usize,
        is_end_site: bool,
        depth: usize,
    ) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(self.unexpected(line, "a shallower hierarchy", "JOINT"));
        }
        let open_line = self.expect("{")?;
        self.expect("OFFSET")?;
        let offset = Vector3::new(
            self.number("OFFSET x")?,
            self.number("OFFSET y")?,
            self.number("OFFSET z")?,
        );
        let mut channels = Vec::new();
        if !is_end_site && self.peek().map(|t| t.1) == Some("CHANNELS") {
            channels = self.channels()?;
        }
        let index = self.nodes.len();
        self.nodes.push(BvhNode {
            name,
            parent,
            offset,
            first_channel: self.num_channels,
            channels,
            is_end_site,
            line,
        });
        self.num_channels += self.nodes[index].channels.len();
        let mut has_end_site = false;
        loop {
            let Some((tok_line, tok)) = self.peek() else {
                return Err(MocapError::UnbalancedBraces {
                    file: self.file.to_owned(),
                    line: self.end_line,
                    detail: format!("'{{' opened at line {open_line} is never closed"),
                });
            };
            match (tok, is_end_site) {
                ("}", _) => {
                    self.pos += 1;
                    return Ok(());
                }
                ("JOINT", false) => {
                    self.pos += 1;
                    let (_, child) = self.next("a joint name")?;
                    self.joint(child.to_owned(), Some(index), tok_line, false, depth + 1)?;
                }
                ("End", false) => {
                    // A leaf's end, once: more would be nodes without data, each costing a
                    // pose per frame (see `MAX_JOINT_POSES`).
                    if has_end_site {
                        return Err(self.unexpected(tok_line, "'}' after the End Site", "End"));
                    }
                    has_end_site = true;
                    self.pos += 1;
                    self.expect("Site")?;
                    let child = format!("{}_end", self.nodes[index].name);
                    self.joint(child, Some(index), tok_line, true, depth + 1)?;
                }
                ("{", _) => {
                    return Err(MocapError::UnbalancedBraces {
                        file: self.file.to_owned(),
                        line: tok_line,
                        detail: "'{' without a joint name before it".to_owned(),
                    });
                }
                (_, false) => {
                    return Err(self.unexpected(tok_line, "'JOINT', 'End Site' or '}'", tok));
                }
                (_, true) => {
                    return Err(self.unexpected(tok_line, "'}' closing the End Site", tok));
                }
            }
        }
    }

    fn channels(&mut self) -> Result<Vec<Channel>> {
        let line = self.expect("CHANNELS")?;
        let (count_line, count_tok) = self.next("the channel count")?;
        let declared: usize = count_tok
            .parse()
            .map_err(|_| self.unexpected(count_line, "a channel count", count_tok))?;
        // Channel names are on the CHANNELS line; count them there so that a wrong count is
        // reported as such rather than as a stray token further down.
        let mut listed = 0;
        while let Some((l, _)) = self.tokens.get(self.pos + listed) {
            if *l != line {
                break;
            }
            listed += 1;
        }
        if listed != declared {
            return Err(MocapError::ChannelCount {
                file: self.file.to_owned(),
                line,
                declared,
                listed,
            });
        }
        let mut channels = Vec::with_capacity(declared);
        for _ in 0..declared {
            let (l, tok) = self.next("a channel name")?;
            let ch = Channel::from_name(tok).ok_or_else(|| MocapError::UnknownChannel {
                file: self.file.to_owned(),
                line: l,
                name: tok.to_owned(),
            })?;
            channels.push(ch);
        }
        Ok(channels)
    }
}

/// Largest frame value taken: 10^5 file units is a kilometre in centimetres (100 km in
/// metres), and 10^5 degrees is 278 turns of a joint. Larger values are corrupt numbers,
/// caught here with their line instead of as positions out of range after the conversion.
pub(crate) const MAX_FRAME_VALUE: f64 = 1e5;

pub(crate) fn parse_finite(tok: &str, file: &str, line: usize, what: &str) -> Result<f64> {
    let value: f64 = tok.parse().map_err(|_| MocapError::NotANumber {
        file: file.to_owned(),
        line,
        what: what.to_owned(),
        token: tok.to_owned(),
    })?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(MocapError::NotFinite {
            file: file.to_owned(),
            line,
            what: what.to_owned(),
            value,
        })
    }
}

/// Reads `Frames:`, `Frame Time:` and the frame lines, starting at line index `start`
/// (0-based: the line after `MOTION`).
fn parse_motion(
    text: &str,
    num_lines: usize,
    start: usize,
    (num_channels, num_nodes): (usize, usize),
    file: &str,
) -> Result<(usize, f64, Vec<f64>)> {
    let last_line = num_lines.max(1);
    let mut rest = text
        .lines()
        .enumerate()
        .skip(start)
        .filter(|(_, l)| !l.trim().is_empty());
    let eof = |expected: &str| MocapError::UnexpectedEof {
        file: file.to_owned(),
        line: last_line,
        expected: expected.to_owned(),
    };
    let (i, l) = rest.next().ok_or_else(|| eof("'Frames:'"))?;
    let frames_tok = header_value(l, "Frames:").ok_or_else(|| MocapError::Unexpected {
        file: file.to_owned(),
        line: i + 1,
        expected: "'Frames: <count>'".to_owned(),
        found: l.trim().to_owned(),
    })?;
    let declared: usize = frames_tok.parse().map_err(|_| MocapError::NotANumber {
        file: file.to_owned(),
        line: i + 1,
        what: "frame count".to_owned(),
        token: frames_tok.to_owned(),
    })?;
    let (i, l) = rest.next().ok_or_else(|| eof("'Frame Time:'"))?;
    let time_tok = header_value(l, "Frame Time:").ok_or_else(|| MocapError::Unexpected {
        file: file.to_owned(),
        line: i + 1,
        expected: "'Frame Time: <seconds>'".to_owned(),
        found: l.trim().to_owned(),
    })?;
    let frame_time_s = parse_finite(time_tok, file, i + 1, "frame time")?;
    if frame_time_s <= 0.0 {
        return Err(MocapError::BadFrameTime {
            file: file.to_owned(),
            line: i + 1,
            value: frame_time_s,
        });
    }
    // Cap the up-front reservation: the header's count is not trusted.
    let mut values = Vec::with_capacity(
        declared
            .min(num_lines)
            .saturating_mul(num_channels)
            .min(MAX_RESERVED_VALUES),
    );
    let mut found = 0;
    for (i, l) in rest {
        if found == declared {
            return Err(MocapError::TooManyFrames {
                file: file.to_owned(),
                line: i + 1,
                declared,
                found: found + 1,
            });
        }
        if (found + 1).saturating_mul(num_nodes.max(1)) > MAX_JOINT_POSES {
            return Err(MocapError::TooLarge {
                file: file.to_owned(),
                line: i + 1,
                num_nodes,
                max: MAX_JOINT_POSES,
            });
        }
        let before = values.len();
        for (k, tok) in l.split_whitespace().enumerate() {
            let what = || format!("frame value {}", k + 1);
            let value = parse_finite(tok, file, i + 1, &what())?;
            if value.abs() > MAX_FRAME_VALUE {
                return Err(MocapError::Implausible {
                    file: file.to_owned(),
                    line: i + 1,
                    what: what(),
                    token: tok.to_owned(),
                    max: MAX_FRAME_VALUE,
                });
            }
            values.push(value);
        }
        let count = values.len() - before;
        if count != num_channels {
            return Err(MocapError::WrongValueCount {
                file: file.to_owned(),
                line: i + 1,
                expected: num_channels,
                found: count,
            });
        }
        found += 1;
    }
    if found < declared {
        return Err(MocapError::Truncated {
            file: file.to_owned(),
            line: last_line,
            declared,
            found,
        });
    }
    Ok((declared, frame_time_s, values))
}

/// `"Frames: 12"` → `Some("12")` for `key = "Frames:"`. Tolerates `Frames:12` and extra spaces
/// (`Frame  Time:`).
fn header_value<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let mut rest = line.trim_start();
    for word in key.split_whitespace() {
        rest = rest.strip_prefix(word)?.trim_start();
    }
    let mut toks = rest.split_whitespace();
    let value = toks.next()?;
    toks.next().is_none().then_some(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines: 1 HIERARCHY, 2 ROOT, 3 {, 4 OFFSET, 5 CHANNELS, 6 JOINT, 7 {, 8 OFFSET, 9 CHANNELS,
    /// 10 End Site, 11 {, 12 OFFSET, 13 }, 14 }, 15 }, 16 MOTION, 17 Frames, 18 Frame Time,
    /// 19–20 frames.
    const GOOD: &str = "HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
\tJOINT Spine
\t{
\t\tOFFSET 0 1.5 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 1 0
\t\t}
\t}
}
MOTION
Frames: 2
Frame Time: .0083333
0 17 0 0 0 0 10 20 30
1 17 0 0 0 0 10 20 30
";

    fn err(text: &str) -> String {
        parse_bvh(text, "t.bvh").unwrap_err().to_string()
    }

    #[test]
    fn a_byte_order_mark_before_the_hierarchy_is_skipped() {
        let marked = format!("\u{feff}{GOOD}");
        assert_eq!(
            parse_bvh(&marked, "t.bvh").unwrap(),
            parse_bvh(GOOD, "t.bvh").unwrap()
        );
    }

    #[test]
    fn hierarchy_channels_and_frames_are_read_as_written() {
        let bvh = parse_bvh(GOOD, "t.bvh").unwrap();
        assert_eq!(bvh.nodes.len(), 3);
        assert_eq!(bvh.nodes[1].name, "Spine");
        assert_eq!(bvh.nodes[1].parent, Some(0));
        assert_eq!(
            bvh.nodes[1].channels,
            [Channel::Zrotation, Channel::Xrotation, Channel::Yrotation]
        );
        assert_eq!(bvh.nodes[1].first_channel, 6);
        assert_eq!(bvh.nodes[2].name, "Spine_end");
        assert!(bvh.nodes[2].is_end_site);
        assert_eq!(bvh.num_channels, 9);
        assert_eq!(bvh.num_frames, 2);
        assert_eq!(bvh.frame(1).unwrap()[0], 1.0);
        assert!(bvh.frame(2).is_none());
        assert!((bvh.frame_time_s - 0.0083333).abs() < 1e-15);
    }

    #[test]
    fn truncated_motion_names_the_last_line() {
        let text = GOOD.replace("Frames: 2", "Frames: 3");
        assert_eq!(
            err(&text),
            "t.bvh:20: truncated motion data: 'Frames: 3' but only 2 frame lines"
        );
        let cut = &GOOD[..GOOD.find("MOTION").unwrap() + 7];
        assert_eq!(
            err(cut),
            "t.bvh:16: unexpected end of file, expected 'Frames:'"
        );
    }

    #[test]
    fn extra_frame_is_a_count_mismatch() {
        let text = GOOD.replace("Frames: 2", "Frames: 1");
        assert_eq!(
            err(&text),
            "t.bvh:20: frame count mismatch: 'Frames: 1' but frame line 2 starts here"
        );
    }

    #[test]
    fn missing_value_on_a_frame_line_is_reported_with_the_counts() {
        let text = GOOD.replace("1 17 0 0 0 0 10 20 30", "1 17 0 0 0 0 10 20");
        assert_eq!(
            err(&text),
            "t.bvh:20: frame line has 8 values, expected 9 (one per channel)"
        );
    }

    #[test]
    fn nan_and_garbage_values_are_rejected() {
        let text = GOOD.replace("1 17 0 0 0 0 10 20 30", "1 17 0 0 NaN 0 10 20 30");
        assert_eq!(
            err(&text),
            "t.bvh:20: frame value 5 is NaN, expected a finite number"
        );
        let text = GOOD.replace("0 17 0 0 0 0 10 20 30", "0 17 0 0 0 0 10 2x 30");
        assert_eq!(err(&text), "t.bvh:19: frame value 8 '2x' is not a number");
        let text = GOOD.replace("OFFSET 0 1.5 0", "OFFSET 0 inf 0");
        assert_eq!(
            err(&text),
            "t.bvh:8: OFFSET y is inf, expected a finite number"
        );
        // Finite but corrupt: named on its own line, not as a position out of range later.
        let text = GOOD.replace("1 17 0 0 0 0 10 20 30", "1 17 0 1e300 0 0 10 20 30");
        assert_eq!(
            err(&text),
            "t.bvh:20: frame value 4 is 1e300, beyond any motion capture (at most 100000 in size)"
        );
    }

    #[test]
    fn bad_channels_count_is_reported_on_its_line() {
        let text = GOOD.replace("CHANNELS 3 Zrotation", "CHANNELS 4 Zrotation");
        assert_eq!(
            err(&text),
            "t.bvh:9: CHANNELS declares 4 channels but lists 3"
        );
        let text = GOOD.replace(
            "CHANNELS 3 Zrotation Xrotation",
            "CHANNELS 3 Zrotation Wrotation",
        );
        assert!(
            err(&text).starts_with("t.bvh:9: unknown channel name 'Wrotation'"),
            "{}",
            err(&text)
        );
    }

    #[test]
    fn unbalanced_braces_name_the_unclosed_or_stray_brace() {
        // Drop the '}' closing Spine (line 14): the root's '}' closes Spine, the root stays open.
        let lines: Vec<&str> = GOOD.lines().collect();
        let missing: String = lines
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != 13)
            .map(|(_, l)| format!("{l}\n"))
            .collect();
        assert_eq!(
            err(&missing),
            "t.bvh:15: unbalanced braces: '{' opened at line 3 is never closed"
        );
        let extra = GOOD.replace("}\nMOTION", "}\n}\nMOTION");
        assert_eq!(
            err(&extra),
            "t.bvh:16: unbalanced braces: '}' without a matching '{'"
        );
    }

    #[test]
    fn zero_frame_time_is_rejected() {
        let text = GOOD.replace("Frame Time: .0083333", "Frame Time: 0");
        assert_eq!(err(&text), "t.bvh:18: frame time 0 s must be positive");
        let text = GOOD.replace("Frame Time: .0083333", "Frame Time: -0.01");
        assert_eq!(err(&text), "t.bvh:18: frame time -0.01 s must be positive");
    }

    #[test]
    fn missing_motion_and_stray_tokens_are_syntax_errors() {
        let head = &GOOD[..GOOD.find("MOTION").unwrap()];
        assert_eq!(
            err(head),
            "t.bvh:15: unexpected end of file, expected MOTION"
        );
        let text = GOOD.replace("JOINT Spine", "JOINTS Spine");
        assert_eq!(
            err(&text),
            "t.bvh:6: expected 'JOINT', 'End Site' or '}', found 'JOINTS'"
        );
    }

    #[test]
    fn a_huge_header_reserves_no_more_than_the_file_and_a_joint_ends_once() {
        // 100,000 channels on one line and 65,536 frames declared, none there: the reserve
        // used to be their product (52 GB, an abort); the file is what is wrong.
        let names = vec!["Xrotation"; 100_000].join(" ");
        let text = format!(
            "HIERARCHY\nROOT Hips\n{{\nOFFSET 0 0 0\nCHANNELS 100000 {names}\n}}\nMOTION\nFrames: 65536\nFrame Time: 0.01\n"
        );
        assert!(err(&text).contains("65536"), "{}", err(&text));
        // A second End Site under one joint.
        let text = GOOD.replace(
            "\t\t\tOFFSET 0 1 0\n\t\t}\n",
            "\t\t\tOFFSET 0 1 0\n\t\t}\n\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 1 0\n\t\t}\n",
        );
        assert_eq!(
            err(&text),
            "t.bvh:14: expected '}' after the End Site, found 'End'"
        );
    }

    #[test]
    fn a_file_past_the_joint_pose_limit_is_refused_where_it_passes_it() {
        // 1,000 joints without channels, each with its end site, under a one-channel root:
        // 2,001 nodes, so the 8,385th frame passes 2^24 joint poses (a 40-kB file that would
        // have taken a gigabyte converted).
        let mut text =
            String::from("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n");
        for k in 0..1_000 {
            text.push_str(&format!(
                "JOINT j{k}\n{{\nOFFSET 0 0 0\nEnd Site\n{{\nOFFSET 0 1 0\n}}\n}}\n"
            ));
        }
        text.push_str("}\nMOTION\nFrames: 9000\nFrame Time: 0.01\n");
        let frames_from = text.lines().count() + 1;
        text.push_str(&"0\n".repeat(9_000));
        let first_past = MAX_JOINT_POSES / 2_001 + 1;
        assert_eq!(
            err(&text),
            format!(
                "t.bvh:{}: too large: 2001 joints and end sites, with this frame more than {MAX_JOINT_POSES} joint poses",
                frames_from + first_past - 1
            )
        );
        // One frame fewer than that is taken.
        let fewer = text
            .lines()
            .take(frames_from + first_past - 2)
            .collect::<Vec<_>>()
            .join("\n")
            .replace("Frames: 9000", &format!("Frames: {}", first_past - 1));
        assert!(parse_bvh(&fewer, "t.bvh").is_ok());
    }

    #[test]
    fn a_file_that_is_not_bvh_is_refused_without_its_content() {
        let text = "# notes\nroot:x:0:0:secret-token:/root:/bin/bash\nHIERARCHY\n";
        let err = parse_bvh(text, "passwd").unwrap_err().to_string();
        assert_eq!(
            err,
            "passwd:1: not a BVH file: expected 'HIERARCHY' (its content is not shown)"
        );
    }
}
