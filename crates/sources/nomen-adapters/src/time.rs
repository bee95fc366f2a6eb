//! Vendor time stamps to nanoseconds: ISO 8601 / RFC 3339 date-times and Unix-epoch seconds.
//!
//! No time-zone database: a date-time carries its offset (`Z`, `+01:00`, `+0000`) or, where the
//! vendor documents its stamps as UTC without saying so in the string (Sewio's `at`), is read as
//! UTC. The parsers live in [`nomen_core::time`], shared with the CSV import.

pub use nomen_core::time::{epoch_secs_to_ns, parse_datetime_ns};
