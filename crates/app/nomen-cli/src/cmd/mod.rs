//! One module per subcommand.

pub mod assemble;
pub mod bench;
pub mod calibrate;
pub mod calibrate_confidence;
pub mod calibrate_rssi;
pub mod config;
pub mod crosswalk;
pub mod demo;
pub mod eval;
pub mod eval_identity;
pub mod experiment;
pub mod explain;
pub mod fit;
pub mod ghosting;
pub mod import;
pub mod log;
pub mod mocap;
pub mod occlusion;
pub mod replay;
pub mod run;
pub mod scenes;
pub mod serve;
pub mod simulate;
pub mod train;
pub mod triangulate;
pub mod validate;
