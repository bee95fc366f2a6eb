//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong while reading a BVH file or an ASF/AMC pair, or converting one
/// to the canonical skeleton.
///
/// Messages are lower-case and start with `file:line` where a line is known (lines count from 1).
#[derive(Debug, Error)]
pub enum MocapError {
    /// The file could not be read.
    #[error("{path}: cannot read: {io}")]
    Io {
        /// The path that was opened.
        path: String,
        /// The operating system's error.
        #[source]
        io: std::io::Error,
    },
    /// The text ended where more was required.
    #[error("{file}:{line}: unexpected end of file, expected {expected}")]
    UnexpectedEof {
        /// Source name (file name).
        file: String,
        /// The last line of the text.
        line: usize,
        /// What the parser was looking for.
        expected: String,
    },
    /// An input read through [`nomen_core::bounded`] that passed one of its limits (a line or
    /// the file too long), could not be read, or is not text.
    #[error(transparent)]
    Limit(#[from] nomen_core::CoreError),
    /// A BVH hierarchy longer than [`crate::bvh::MAX_BVH_HIERARCHY_BYTES`] (no `MOTION` line
    /// in reach).
    #[error(
        "{file}:{line}: the hierarchy runs past {}, the longest a BVH hierarchy may have, without a MOTION line",
        nomen_core::bounded::describe_bytes(*max_bytes as u64)
    )]
    HierarchyTooLong {
        /// Source name (file name).
        file: String,
        /// The line that passes the limit.
        line: usize,
        /// The longest hierarchy taken, bytes.
        max_bytes: usize,
    },
    /// Text that does not start as its kind does (a BVH file with `HIERARCHY`, an ASF file with
    /// a `:` section, an AMC file with a header keyword or a frame number). Its content is not
    /// repeated: a wrong path may name any file.
    #[error("{file}:{line}: not {kind}: expected {expected} (its content is not shown)")]
    NotOfKind {
        /// Source name (file name).
        file: String,
        /// The first line that is not blank or a comment.
        line: usize,
        /// The kind of file expected: `a BVH file`.
        kind: &'static str,
        /// What it should start with.
        expected: &'static str,
    },
    /// A token that does not fit the BVH grammar here.
    #[error("{file}:{line}: expected {expected}, found '{found}'")]
    Unexpected {
        /// Source name (file name).
        file: String,
        /// Line of the offending token.
        line: usize,
        /// What the parser was looking for.
        expected: String,
        /// The token found instead.
        found: String,
    },
    /// `{` and `}` do not pair up.
    #[error("{file}:{line}: unbalanced braces: {detail}")]
    UnbalancedBraces {
        /// Source name (file name).
        file: String,
        /// Line where the imbalance shows.
        line: usize,
        /// Which brace is unmatched.
        detail: String,
    },
    /// A `CHANNELS` line whose count does not match the names listed.
    #[error("{file}:{line}: CHANNELS declares {declared} channels but lists {listed}")]
    ChannelCount {
        /// Source name (file name).
        file: String,
        /// Line of the `CHANNELS` keyword.
        line: usize,
        /// The number written after `CHANNELS`.
        declared: usize,
        /// The number of channel names on the line.
        listed: usize,
    },
    /// A channel name other than `X/Y/Z` + `position`/`rotation`.
    #[error(
        "{file}:{line}: unknown channel name '{name}' (expected Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation)"
    )]
    UnknownChannel {
        /// Source name (file name).
        file: String,
        /// Line of the channel name.
        line: usize,
        /// The unrecognised name.
        name: String,
    },
    /// A token that should be a number but does not parse as one.
    #[error("{file}:{line}: {what} '{token}' is not a number")]
    NotANumber {
        /// Source name (file name).
        file: String,
        /// Line of the token.
        line: usize,
        /// What the number was supposed to be (`OFFSET value`, `frame value 7`, ...).
        what: String,
        /// The token as written.
        token: String,
    },
    /// A number that parses but is NaN or infinite.
    #[error("{file}:{line}: {what} is {value}, expected a finite number")]
    NotFinite {
        /// Source name (file name).
        file: String,
        /// Line of the value.
        line: usize,
        /// What the number was supposed to be.
        what: String,
        /// The value read.
        value: f64,
    },
    /// A frame value far beyond any motion capture: a position beyond a kilometre in any
    /// usual unit, or a rotation of thousands of turns (a corrupt number).
    #[error("{file}:{line}: {what} is {token}, beyond any motion capture (at most {max} in size)")]
    Implausible {
        /// Source name (file name).
        file: String,
        /// Line of the value.
        line: usize,
        /// What the number was supposed to be.
        what: String,
        /// The value as written.
        token: String,
        /// The largest size accepted.
        max: f64,
    },
    /// A frame line with more or fewer values than the hierarchy has channels.
    #[error("{file}:{line}: frame line has {found} values, expected {expected} (one per channel)")]
    WrongValueCount {
        /// Source name (file name).
        file: String,
        /// Line of the frame.
        line: usize,
        /// Total number of channels in the hierarchy.
        expected: usize,
        /// Number of values on the line.
        found: usize,
    },
    /// Fewer frame lines than `Frames:` declares.
    #[error(
        "{file}:{line}: truncated motion data: 'Frames: {declared}' but only {found} frame lines"
    )]
    Truncated {
        /// Source name (file name).
        file: String,
        /// The last line of the text.
        line: usize,
        /// The count in the header.
        declared: usize,
        /// Frame lines present.
        found: usize,
    },
    /// More frame lines than `Frames:` declares.
    #[error(
        "{file}:{line}: frame count mismatch: 'Frames: {declared}' but frame line {found} starts here"
    )]
    TooManyFrames {
        /// Source name (file name).
        file: String,
        /// Line of the first frame beyond the declared count.
        line: usize,
        /// The count in the header.
        declared: usize,
        /// The 1-based index of the extra frame.
        found: usize,
    },
    /// The file holds more joint poses (nodes × frames) than [`crate::bvh::MAX_JOINT_POSES`].
    #[error(
        "{file}:{line}: too large: {num_nodes} joints and end sites, with this frame more than {max} joint poses"
    )]
    TooLarge {
        /// Source name (file name).
        file: String,
        /// Line of the first frame past the limit.
        line: usize,
        /// Joints and end sites in the hierarchy.
        num_nodes: usize,
        /// The most joint poses a file may hold.
        max: usize,
    },
    /// A bone name that the ASF's `:bonedata` does not define (in `:hierarchy` or an AMC
    /// frame), or `root` where a bone is required.
    #[error("{file}:{line}: unknown bone '{name}' (not defined in the skeleton's :bonedata)")]
    UnknownBone {
        /// Source name (file name).
        file: String,
        /// Line of the name.
        line: usize,
        /// The name as written.
        name: String,
    },
    /// A bone defined twice in `:bonedata`, or given values twice in one AMC frame.
    #[error("{file}:{line}: bone '{name}' appears twice (first at line {first_line})")]
    DuplicateBone {
        /// Source name (file name).
        file: String,
        /// Line of the second appearance.
        line: usize,
        /// The bone's name.
        name: String,
        /// Line of the first appearance.
        first_line: usize,
    },
    /// A bone definition that cannot be used (no direction, a negative length, an unsupported
    /// degree of freedom, limits that do not pair with the dofs, ...).
    #[error("{file}:{line}: bone '{bone}': {detail}")]
    BadBone {
        /// Source name (file name).
        file: String,
        /// Line of the offending entry (or the bone's `begin`).
        line: usize,
        /// The bone's name (empty when it has none yet).
        bone: String,
        /// What is wrong.
        detail: String,
    },
    /// An ASF `:hierarchy` that is not a tree rooted at `root`.
    #[error("{file}:{line}: bad :hierarchy: {detail}")]
    Hierarchy {
        /// Source name (file name).
        file: String,
        /// Line of the offending hierarchy entry.
        line: usize,
        /// What is wrong.
        detail: String,
    },
    /// An AMC bone line whose number of values differs from the bone's degrees of freedom.
    #[error("{file}:{line}: bone '{bone}' has {found} values, expected {expected} (dof: {dofs})")]
    DofValueCount {
        /// Source name (file name).
        file: String,
        /// Line of the bone's values.
        line: usize,
        /// The bone's name.
        bone: String,
        /// Number of degrees of freedom the ASF gives the bone.
        expected: usize,
        /// Number of values on the line.
        found: usize,
        /// The degrees of freedom in order, space-separated (`rx ry rz`).
        dofs: String,
    },
    /// An AMC frame number that does not follow the previous one.
    #[error("{file}:{line}: frame number {found} out of order, expected {expected}")]
    FrameOrder {
        /// Source name (file name).
        file: String,
        /// Line of the frame number.
        line: usize,
        /// The previous frame number plus one.
        expected: u64,
        /// The number written.
        found: u64,
    },
    /// An AMC frame that ends (at the next frame number or the end of the file) before every
    /// bone with degrees of freedom has its values.
    #[error(
        "{file}:{line}: frame {frame} (from line {frame_line}) ends without values for {missing}"
    )]
    IncompleteFrame {
        /// Source name (file name).
        file: String,
        /// Line where the frame ends: the next frame number, or the last line.
        line: usize,
        /// The frame number.
        frame: u64,
        /// Line of the frame number.
        frame_line: usize,
        /// The bones without values, comma-separated.
        missing: String,
    },
    /// `Frame Time:` is zero or negative.
    #[error("{file}:{line}: frame time {value} s must be positive")]
    BadFrameTime {
        /// Source name (file name).
        file: String,
        /// Line of `Frame Time:`.
        line: usize,
        /// The value read.
        value: f64,
    },
    /// Some canonical joints have no BVH joint in any known naming variant.
    #[error(
        "{file}: cannot map to the canonical skeleton: no joint found for {missing} (closest naming variant: {variant}, which names them {expected})"
    )]
    MissingJoints {
        /// Source name (file name).
        file: String,
        /// The canonical joints that could not be found, comma-separated.
        missing: String,
        /// The naming variant that matched best.
        variant: String,
        /// The BVH names that variant looks for, comma-separated.
        expected: String,
    },
    /// A conversion option out of range.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// Two clips that should share a clock do not.
    #[error("{first} and {second} cannot share a clock: {detail}")]
    PairMismatch {
        /// Source name of the first clip.
        first: String,
        /// Source name of the second clip.
        second: String,
        /// What differs.
        detail: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, MocapError>;
