//! Parsers for the recording formats the fits read. Each takes the file's text and a source name
//! (used in `name:line` errors) and does no I/O itself.

pub mod imu;
pub mod kolakowski;
pub mod lias;

pub use imu::{
    AccelUnit, GyroUnit, ImuCsvFormat, ImuRecording, ImuRow, STANDARD_GRAVITY_MPS2, parse_imu_csv,
};
pub use kolakowski::{
    RssiAnchor, RssiCsvFormat, RssiRecording, RssiRow, parse_anchors_csv, parse_rssi_csv,
};
pub use lias::{
    BodyFlip, MocapRecording, MocapRow, QuatConvention, QuatOrder, UwbCsvFormat, UwbRecording,
    UwbRow, parse_local_time_s, parse_mocap_csv, parse_uwb_csv,
};
