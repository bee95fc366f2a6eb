//! `nomen serve --record DIR`: the inputs the engine took, its outputs, the events and the
//! health reports of each session in MCAP files (`nomen-mcap`), one file per session, a new
//! part when a file passes its size. A file is written as `NAME.mcap.partial` and renamed to
//! `NAME.mcap` once closed; the chunk being filled is flushed with every health report, so a
//! killed service leaves a `.partial` file that reads up to its last report.

use crate::health::HealthReport;
use crate::session::Output;
use crate::topics::{EVENT_TOPIC, HEALTH_TOPIC};
use crate::{LiveError, Result};
use nomen_core::{Message, Registry};
use nomen_mcap::{Channel, McapWriter};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// The smallest `record_max_mb` taken: a file holds at least one chunk (1 MiB).
pub const MIN_RECORD_MB: u64 = 1;
/// The largest `record_max_mb` taken: 1 TiB.
pub const MAX_RECORD_MB: u64 = 1 << 20;

/// The event channel of a recorded session.
pub const EVENT_CHANNEL: Channel = Channel {
    topic: EVENT_TOPIC,
    schema_name: "nomen.event",
    schema: include_str!("../schemas/event.json"),
};

/// The health channel of a recorded session.
pub const HEALTH_CHANNEL: Channel = Channel {
    topic: HEALTH_TOPIC,
    schema_name: "nomen.health",
    schema: include_str!("../schemas/health.json"),
};

/// Where and how sessions are recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordOptions {
    /// The folder of the files (created if missing).
    pub dir: PathBuf,
    /// A file that passes this size is closed and the session goes on in a new part, bytes.
    pub max_file_bytes: u64,
}

struct Part {
    writer: McapWriter<BufWriter<File>>,
    partial: PathBuf,
    path: PathBuf,
}

/// The recorder of a service: one open file at a time.
pub struct Recorder {
    options: RecordOptions,
    /// The wall clock's Unix time at `started`, ns: log times are Unix-epoch nanoseconds that
    /// follow the monotonic clock.
    started_unix_ns: u64,
    started: Instant,
    current: Option<Part>,
    session: u64,
    session_stamp: String,
    part: u32,
    registry: Option<Registry>,
    written: Vec<PathBuf>,
}

impl Recorder {
    /// A recorder into `options.dir` (created if missing); no file is opened before a session.
    pub fn new(options: RecordOptions) -> Result<Self> {
        std::fs::create_dir_all(&options.dir).map_err(|e| LiveError::Io {
            what: format!(
                "cannot create the recording folder {}",
                options.dir.display()
            ),
            source: e,
        })?;
        let started_unix_ns = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
        Ok(Recorder {
            options,
            started_unix_ns,
            started: Instant::now(),
            current: None,
            session: 0,
            session_stamp: String::new(),
            part: 0,
            registry: None,
            written: Vec::new(),
        })
    }

    /// The log time of wall-clock instant `at`, Unix-epoch ns.
    pub fn log_time_ns(&self, at: Instant) -> u64 {
        let since = u64::try_from(at.saturating_duration_since(self.started).as_nanos())
            .unwrap_or(u64::MAX);
        self.started_unix_ns.saturating_add(since)
    }

    /// Session `session` starts with `registry`: the previous file is closed, the session's
    /// first opened, its registry written.
    pub fn begin_session(&mut self, session: u64, registry: &Registry, at: Instant) -> Result<()> {
        self.close()?;
        self.session = session;
        self.session_stamp = utc_stamp(self.log_time_ns(at) / 1_000_000_000);
        self.part = 0;
        self.registry = Some(registry.clone());
        self.open(at)
    }

    /// An input the engine took, arrived at `at`.
    pub fn input(&mut self, msg: &Message, at: Instant) -> Result<()> {
        let log_time = self.log_time_ns(at);
        if let Some(part) = self.current.as_mut() {
            part.writer
                .write_message(msg, log_time)
                .map_err(mcap_error)?;
        }
        self.rotate_if_full(at)
    }

    /// A batch of outputs (decisions, events), at `at`.
    pub fn outputs(&mut self, outputs: &[Output], at: Instant) -> Result<()> {
        let log_time = self.log_time_ns(at);
        if let Some(part) = self.current.as_mut() {
            let mut payload = Vec::new();
            for o in outputs {
                match o {
                    Output::Decision(m) => {
                        part.writer.write_message(m, log_time).map_err(mcap_error)?;
                    }
                    Output::Event(e) => {
                        payload.clear();
                        // Our own values always serialise.
                        let _ = serde_json::to_writer(&mut payload, e);
                        part.writer
                            .write_json(EVENT_TOPIC, &payload, log_time)
                            .map_err(mcap_error)?;
                    }
                }
            }
        }
        self.rotate_if_full(at)
    }

    /// A health report, at `at`; the file's chunk is flushed with it.
    pub fn health(&mut self, report: &HealthReport, at: Instant) -> Result<()> {
        let log_time = self.log_time_ns(at);
        if let Some(part) = self.current.as_mut() {
            let payload = serde_json::to_vec(report).unwrap_or_default();
            part.writer
                .write_json(HEALTH_TOPIC, &payload, log_time)
                .map_err(mcap_error)?;
            part.writer.flush().map_err(mcap_error)?;
        }
        self.rotate_if_full(at)
    }

    /// Closes the open file; returns every file written, in order.
    pub fn finish(mut self) -> Result<Vec<PathBuf>> {
        self.close()?;
        Ok(std::mem::take(&mut self.written))
    }

    fn rotate_if_full(&mut self, at: Instant) -> Result<()> {
        let is_full = self
            .current
            .as_ref()
            .is_some_and(|p| p.writer.num_bytes() >= self.options.max_file_bytes);
        if is_full {
            self.close()?;
            self.part += 1;
            self.open(at)?;
        }
        Ok(())
    }

    fn open(&mut self, at: Instant) -> Result<()> {
        let Some(registry) = &self.registry else {
            return Ok(());
        };
        let name = format!(
            "nomen-{}-s{}-{:03}.mcap",
            self.session_stamp, self.session, self.part
        );
        let path = self.options.dir.join(name);
        let partial = partial_path(&path);
        let file = File::create(&partial).map_err(|e| LiveError::Io {
            what: format!("cannot create {}", partial.display()),
            source: e,
        })?;
        let mut writer = McapWriter::new(
            BufWriter::with_capacity(1 << 16, file),
            &partial.display().to_string(),
            &[EVENT_CHANNEL, HEALTH_CHANNEL],
        )
        .map_err(mcap_error)?;
        // Every part starts with the registry, so that each reads alone.
        writer
            .write_registry(registry, self.log_time_ns(at))
            .map_err(mcap_error)?;
        self.current = Some(Part {
            writer,
            partial,
            path,
        });
        Ok(())
    }

    fn close(&mut self) -> Result<()> {
        let Some(part) = self.current.take() else {
            return Ok(());
        };
        let out = part.writer.finish().map_err(mcap_error)?;
        let file = out.into_inner().map_err(|e| LiveError::Io {
            what: format!("cannot write {}", part.partial.display()),
            source: e.into_error(),
        })?;
        file.sync_all().map_err(|e| LiveError::Io {
            what: format!("cannot write {}", part.partial.display()),
            source: e,
        })?;
        std::fs::rename(&part.partial, &part.path).map_err(|e| LiveError::Io {
            what: format!(
                "cannot give {} its name {}",
                part.partial.display(),
                part.path.display()
            ),
            source: e,
        })?;
        self.written.push(part.path);
        Ok(())
    }
}

fn mcap_error(e: nomen_mcap::McapFileError) -> LiveError {
    LiveError::Record(e.to_string())
}

/// `PATH.partial`.
fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_owned();
    name.push(".partial");
    path.with_file_name(name)
}

/// `YYYYMMDDTHHMMSSZ` of a Unix time, s (UTC; Howard Hinnant's `civil_from_days`).
fn utc_stamp(unix_s: u64) -> String {
    let days = i64::try_from(unix_s / 86_400).unwrap_or(0);
    let secs = unix_s % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z",
        secs / 3600,
        secs / 60 % 60,
        secs % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_stamps_match_known_dates() {
        assert_eq!(utc_stamp(0), "19700101T000000Z");
        // 2000-02-29 12:34:56 UTC, a leap day.
        assert_eq!(utc_stamp(951_827_696), "20000229T123456Z");
        // 2026-12-07 09:22:08 UTC.
        assert_eq!(utc_stamp(1_796_635_328), "20261207T092208Z");
    }

    #[test]
    fn a_full_file_goes_on_in_a_new_part_that_reads_alone() {
        let dir = tempfile::tempdir().unwrap();
        let registry: Registry = serde_json::from_str(
            r#"{"subjects":[{"id":"ana","wears":[{"device":"w1","kind":"imu","site":"left_wrist"}]}]}"#,
        )
        .unwrap();
        let mut recorder = Recorder::new(RecordOptions {
            dir: dir.path().join("rec"),
            max_file_bytes: 16 << 10,
        })
        .unwrap();
        let start = Instant::now();
        recorder.begin_session(1, &registry, start).unwrap();
        let mut health = crate::health::Health::default();
        let mut inputs = Vec::new();
        for k in 0..2000i64 {
            let m: Message = serde_json::from_str(&format!(
                r#"{{"type":"imu","t":{},"device":"w1","accel_mps2":[0.1,0.2,9.8],"gyro_radps":[0.0,0.1,{k}e-4]}}"#,
                k * 10_000_000
            ))
            .unwrap();
            let at = start + std::time::Duration::from_millis(k as u64 * 10);
            recorder.input(&m, at).unwrap();
            inputs.push(m);
            // A health report flushes the chunk: the file's size grows with it.
            if k % 100 == 99 {
                recorder.health(&health.report(0.0, 1, (0, 1)), at).unwrap();
            }
        }
        let files = recorder.finish().unwrap();
        assert!(files.len() > 2, "{files:?}");
        let mut read = Vec::new();
        for (i, f) in files.iter().enumerate() {
            let name = f.file_name().unwrap().to_str().unwrap();
            assert!(name.ends_with(&format!("-s1-{i:03}.mcap")), "{name}");
            assert!(f.is_file());
            let reader =
                nomen_mcap::open_recording(f, nomen_recording::ReadOptions::default()).unwrap();
            // Every part carries the registry.
            assert_eq!(reader.header().registry.as_ref(), Some(&registry));
            read.extend(reader.map(std::result::Result::unwrap));
        }
        assert_eq!(read, inputs);
        // Nothing is left under a temporary name.
        for e in std::fs::read_dir(dir.path().join("rec")).unwrap() {
            let path = e.unwrap().path();
            assert_eq!(path.extension().unwrap(), "mcap", "{}", path.display());
        }
    }

    #[test]
    fn every_schema_is_a_json_object_schema() {
        for c in [EVENT_CHANNEL, HEALTH_CHANNEL] {
            let schema: serde_json::Value = serde_json::from_str(c.schema).unwrap();
            assert_eq!(schema["type"], "object");
            assert_eq!(schema["title"], c.schema_name);
        }
    }
}
