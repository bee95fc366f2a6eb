//! Writing nomen's messages to MCAP.

use crate::channels::{Channel, MESSAGE_CHANNELS, REGISTRY, message_channel};
use crate::{McapFileError, Result};
use mcap::records::MessageHeader;
use nomen_core::{Message, Registry};
use std::collections::BTreeMap;
use std::io::{Seek, SeekFrom, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// The MCAP profile of nomen's files (the header's `profile`).
pub const PROFILE: &str = "nomen";

/// A [`Write`] + [`Seek`] that counts how far the file reaches (shared: `mcap::Writer` keeps
/// its stream to itself until it is finished).
struct Counting<W> {
    inner: W,
    position: u64,
    len: Arc<AtomicU64>,
}

impl<W: Write> Write for Counting<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.position += n as u64;
        self.len.fetch_max(self.position, Ordering::Relaxed);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl<W: Seek> Seek for Counting<W> {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        self.position = self.inner.seek(to)?;
        Ok(self.position)
    }
}

/// Writes nomen's messages to an MCAP file: every channel of [`MESSAGE_CHANNELS`] plus the
/// caller's, JSON payloads (the recording format's lines for messages), zstd-compressed chunks
/// of at most 1 MiB. Log times are nanoseconds since the Unix epoch, as MCAP tools expect.
pub struct McapWriter<W: Write + Seek> {
    writer: mcap::Writer<Counting<W>>,
    len: Arc<AtomicU64>,
    source_name: String,
    /// Channel ids by topic.
    channels: BTreeMap<&'static str, u16>,
    sequence: u32,
    num_messages: u64,
    payload: Vec<u8>,
    /// The newest registry written, as its payload, and how many versions were written.
    registry: Vec<u8>,
    num_registry_versions: u32,
}

impl<W: Write + Seek> McapWriter<W> {
    /// Starts a file on `out` with nomen's channels and `extra` ones (e.g. the live service's
    /// events and health); `source_name` names it in errors.
    pub fn new(out: W, source_name: &str, extra: &[Channel]) -> Result<Self> {
        let mcap_error = |e: mcap::McapError| McapFileError::Mcap {
            source_name: source_name.to_owned(),
            why: e.to_string(),
        };
        let len = Arc::new(AtomicU64::new(0));
        let counting = Counting {
            inner: out,
            position: 0,
            len: Arc::clone(&len),
        };
        let mut writer = mcap::WriteOptions::new()
            .profile(PROFILE)
            .library(format!("nomen-mcap {}", env!("CARGO_PKG_VERSION")))
            .create(counting)
            .map_err(mcap_error)?;
        let mut channels = BTreeMap::new();
        for c in MESSAGE_CHANNELS.iter().chain(extra) {
            let schema_id = writer
                .add_schema(c.schema_name, "jsonschema", c.schema.as_bytes())
                .map_err(mcap_error)?;
            let id = writer
                .add_channel(schema_id, c.topic, "json", &BTreeMap::new())
                .map_err(mcap_error)?;
            channels.insert(c.topic, id);
        }
        Ok(McapWriter {
            writer,
            len,
            source_name: source_name.to_owned(),
            channels,
            sequence: 0,
            num_messages: 0,
            payload: Vec::new(),
            registry: Vec::new(),
            num_registry_versions: 0,
        })
    }

    /// Writes a registry on [`REGISTRY`]: the file's first, or a registry update that applies
    /// to the messages after it, a new version ([`McapWriter::num_registry_versions`]). The
    /// same registry as the newest one is not written again.
    ///
    /// A recording read from the file ([`crate::McapLines`]) has one registry: the first, when
    /// it comes before the inputs; its reading ends at an update. The live service therefore
    /// records each registry version in a file of its own.
    pub fn write_registry(&mut self, registry: &Registry, log_time_ns: u64) -> Result<()> {
        self.payload.clear();
        // Our own values always serialise (finite numbers, string keys).
        let _ = serde_json::to_writer(&mut self.payload, registry);
        if self.num_registry_versions > 0 && self.payload == self.registry {
            return Ok(());
        }
        let payload = std::mem::take(&mut self.payload);
        let written = self.write_json(REGISTRY.topic, &payload, log_time_ns);
        if written.is_ok() {
            self.registry.clone_from(&payload);
            self.num_registry_versions += 1;
        }
        self.payload = payload;
        written
    }

    /// Registry versions written: 0 before the first registry, 2 after one update.
    pub fn num_registry_versions(&self) -> u32 {
        self.num_registry_versions
    }

    /// Writes a message on its kind's channel; ground truth, which has none, is left out
    /// (`Ok(false)`).
    pub fn write_message(&mut self, msg: &Message, log_time_ns: u64) -> Result<bool> {
        let Some(channel) = message_channel(msg) else {
            return Ok(false);
        };
        self.payload.clear();
        let _ = serde_json::to_writer(&mut self.payload, msg);
        let payload = std::mem::take(&mut self.payload);
        let written = self.write_json(channel.topic, &payload, log_time_ns);
        self.payload = payload;
        written.map(|()| true)
    }

    /// Writes a JSON payload on the channel of `topic`.
    pub fn write_json(&mut self, topic: &str, payload: &[u8], log_time_ns: u64) -> Result<()> {
        let Some(&channel_id) = self.channels.get(topic) else {
            return Err(McapFileError::UnknownTopic {
                source_name: self.source_name.clone(),
                topic: topic.to_owned(),
            });
        };
        self.sequence = self.sequence.wrapping_add(1);
        let header = MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: log_time_ns,
            publish_time: log_time_ns,
        };
        self.writer
            .write_to_known_channel(&header, payload)
            .map_err(|e| self.error(e))?;
        self.num_messages += 1;
        Ok(())
    }

    /// Closes the current chunk and flushes it to `out`: what was written so far is readable
    /// even if the process is killed before [`McapWriter::finish`].
    pub fn flush(&mut self) -> Result<()> {
        self.writer.flush().map_err(|e| self.error(e))
    }

    /// Messages written.
    pub fn num_messages(&self) -> u64 {
        self.num_messages
    }

    /// Bytes written to `out` so far (the chunk being filled, at most 1 MiB, is not yet).
    pub fn num_bytes(&self) -> u64 {
        self.len.load(Ordering::Relaxed)
    }

    /// Writes the summary and the footer; returns `out`.
    pub fn finish(mut self) -> Result<W> {
        self.writer.finish().map_err(|e| self.error(e))?;
        let mut counting = self.writer.into_inner();
        counting.flush().map_err(|e| McapFileError::Mcap {
            source_name: self.source_name.clone(),
            why: e.to_string(),
        })?;
        Ok(counting.inner)
    }

    fn error(&self, e: mcap::McapError) -> McapFileError {
        McapFileError::Mcap {
            source_name: self.source_name.clone(),
            why: e.to_string(),
        }
    }
}
