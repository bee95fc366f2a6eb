//! BVH and ASF/AMC motion capture parsing and exact forward kinematics into nomen's canonical
//! skeleton.
//!
//! Three steps, each usable alone:
//!
//! 1. Text in (sans-IO) → [`Bvh`]: hierarchy and channel values (file units, Y up, degrees).
//!    - [`parse_bvh`] reads BVH as written; [`read_bvh_file`] is the same with the file read
//!      for you.
//!    - [`parse_asf`] reads an Acclaim skeleton ([`Asf`]) and [`parse_amc`] one of its motions
//!      into a [`Bvh`] with one node per bone whose forward kinematics are the Acclaim
//!      semantics exactly (see [`amc`]); [`read_asf_amc_files`] reads both files for you. CMU's
//!      ASF lengths are inches × `:units length` ([`Asf::cmu_metres_per_unit`]).
//! 2. [`forward_kinematics`] → a [`JointPose`] per BVH node: exact FK
//!    (`R_joint = R_parent · R_ch1 · R_ch2 · R_ch3` in channel order,
//!    `p_joint = p_parent + R_parent · OFFSET`), lengths scaled to metres, then turned once from
//!    BVH's Y up to nomen's Z up for both positions and rotations. See [`fk`] for what
//!    `world_from_joint` means.
//! 3. [`convert`] / [`convert_pair`] → [`MocapClip`]: the 20 canonical joints per frame (naming
//!    variant detected, see [`mapping`]), the frame rate and scale actually used (headers lie:
//!    override them with [`ConvertOptions`]) and plausibility warnings for wrong units.
//!    [`MocapClip::to_skeletons`] turns a clip into camera-style skeleton observations.
//!
//! Nothing is re-centred; vertical grounding happens only when asked for ([`Grounding`]).
//!
//! ```no_run
//! use nomen_mocap::{ConvertOptions, convert, read_asf_amc_files, read_bvh_file};
//! use nomen_core::{CameraId, SessionTime, TrackId};
//!
//! let bvh = read_bvh_file("02_01.bvh".as_ref())?;
//! let options = ConvertOptions { scale: Some(0.0564444), ..Default::default() };
//! let clip = convert(&bvh, &options)?;
//! for w in &clip.warnings {
//!     eprintln!("{}: warning: {w}", clip.source);
//! }
//! let skeletons = clip.to_skeletons(CameraId::new("mocap"), TrackId(1), SessionTime::ZERO);
//!
//! let walk = read_asf_amc_files("02.asf".as_ref(), "02_01.amc".as_ref())?;
//! let options = ConvertOptions { scale: Some(0.0564444), ..Default::default() };
//! let clip = convert(&walk, &options)?; // 120 Hz: AMC files state no rate, CMU's are 120 Hz
//! # Ok::<(), nomen_mocap::MocapError>(())
//! ```

pub mod amc;
pub mod asf;
pub mod bvh;
pub mod clip;
mod error;
pub mod fk;
pub mod mapping;

pub use amc::{CMU_FRAME_RATE_HZ, parse_amc};
pub use asf::{Asf, AsfBone, parse_asf};
pub use bvh::{Bvh, BvhNode, Channel, parse_bvh};
pub use clip::{
    ConvertOptions, Grounding, MocapClip, MocapWarning, convert, convert_pair, rest_stature_m,
};
pub use error::{MocapError, Result};
pub use fk::{JointPose, forward_kinematics};
pub use mapping::{JointMapping, SkeletonVariant, map_joints};

use nomen_core::bounded::{Limits, MIB_BYTES, read_to_string_bounded};
use std::io::Read;
use std::path::Path;

/// Reads and parses a BVH file; errors name the file by its path.
pub fn read_bvh_file(path: &Path) -> Result<Bvh> {
    let (name, text) = read_text(path)?;
    parse_bvh(&text, &name)
}

/// Reads an ASF skeleton and one of its AMC motions into a [`Bvh`] (see [`amc`]); errors name
/// the file they are in by its path.
pub fn read_asf_amc_files(asf_path: &Path, amc_path: &Path) -> Result<Bvh> {
    let (asf_name, asf_text) = read_text(asf_path)?;
    let asf = parse_asf(&asf_text, &asf_name)?;
    let (amc_name, amc_text) = read_text(amc_path)?;
    parse_amc(&amc_text, &asf, &amc_name)
}

/// The longest line a motion-capture file (BVH, ASF, AMC) may have, bytes: 1 MiB. The longest
/// line of the shared CMU files is 1.4 kB (a BVH frame of 38 joints).
pub const MAX_MOCAP_LINE_BYTES: u64 = MIB_BYTES;

/// The most bytes a motion-capture file may have: 64 MiB, about nine minutes of CMU's 120-Hz
/// BVH and seventeen times the largest shared file (3.7 MB). Parsing holds the text and its
/// frame values (8 bytes for every value, each at least 2 bytes of text): at most five times
/// the file in memory.
pub const MAX_MOCAP_BYTES: u64 = 64 * MIB_BYTES;

/// The limits every motion-capture file is read within.
pub const MOCAP_LIMITS: Limits = Limits::text(
    "a motion-capture file",
    MAX_MOCAP_LINE_BYTES,
    MAX_MOCAP_BYTES,
);

/// The text of a motion-capture file, read within [`MOCAP_LIMITS`]; errors name it by `path`.
pub fn read_mocap_text(path: &Path) -> Result<String> {
    let name = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|io| MocapError::Io {
        path: name.clone(),
        io,
    })?;
    read_mocap_stream(file, &name)
}

/// The text of a motion-capture stream, read within [`MOCAP_LIMITS`]; `source` names it in
/// errors.
pub fn read_mocap_stream(input: impl Read, source: &str) -> Result<String> {
    Ok(read_to_string_bounded(input, source, MOCAP_LIMITS)?)
}

/// The file's text and its path as errors name it.
fn read_text(path: &Path) -> Result<(String, String)> {
    Ok((path.display().to_string(), read_mocap_text(path)?))
}
