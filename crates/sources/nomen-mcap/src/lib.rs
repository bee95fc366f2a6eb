//! MCAP recordings of nomen: inputs, decisions, events and health written on JSON-schema channels, and read back as a recording in log-time order.
//!
//! [`McapWriter`] writes nomen's messages to an MCAP file (one channel per message kind, JSON
//! payloads exactly as the recording format's lines, each channel with its JSON schema); the
//! live service (`nomen serve`) records its sessions with it. [`McapLines`] reads an MCAP file
//! as a recording: a header line carrying the registry of its `nomen/in/registry` channel,
//! then the payload of each input channel's message, in log-time order, so that
//! [`nomen_recording::RecordingReader`] checks them as it checks any recording's lines.
//! [`open_recording`] opens either kind of file by its first bytes. `docs/live.md` lists the
//! channels.

mod channels;
mod error;
mod reader;
mod writer;

pub use channels::{
    Channel, IDENTIFIED, INPUTS, MESSAGE_CHANNELS, REGISTRY, TAG_CORRECTION, message_channel,
};
pub use error::{McapFileError, Result};
pub use reader::{MAX_RECORD_BYTES, McapLines, is_mcap, is_mcap_file, open_recording};
pub use writer::{McapWriter, PROFILE};
