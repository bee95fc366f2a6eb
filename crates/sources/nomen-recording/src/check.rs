//! The rules a message must pass, shared by the reader and the writer: its own values, known ids
//! and time order.

use crate::error::{Pos, RecordingError, Result};
use nomen_core::{DeviceKind, Message, Registry, SessionTime};
use std::collections::{HashMap, HashSet};
use std::sync::Arc;

/// How far back in time a message may be from the latest message so far, by default, for readers
/// (100 ms). Logs written in arrival order from several transports are out of order by about one
/// transport latency; the writer is strict (tolerance 0) unless told otherwise.
pub const DEFAULT_GLOBAL_TOLERANCE_NS: i64 = 100_000_000;

/// How far after every earlier message a reader takes a message only if the next two follow on
/// from it, by default (100 ms, as far as the global tolerance lets messages be out of order). A
/// message further ahead is the first after a pause, which the next two confirm, or out of
/// place (a corrupt timestamp, a line moved earlier): taken at once, it would put the lines it
/// jumped over out of order, every source's beyond the global tolerance and its own source's
/// all, when refusing it costs its own line only.
pub const DEFAULT_MAX_TIME_JUMP_NS: i64 = 100_000_000;

/// Which registry a reader or writer checks ids against.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum IdCheck {
    /// The header's registry; a header without one (`"registry":null`) means no id checks.
    #[default]
    Header,
    /// No id checks, whatever the header says (e.g. to inspect a file with a stale registry).
    Off,
    /// This registry instead of the header's (e.g. a result file checked against the scene's).
    Registry(Registry),
}

/// Registry ids in hash sets, looked up by `&str` without allocating.
#[derive(Clone)]
struct IdIndex {
    devices: HashMap<String, DeviceKind>,
    cameras: HashSet<String>,
    anchors: HashSet<String>,
    antennas: HashSet<String>,
    subjects: HashSet<String>,
}

impl IdIndex {
    fn new(registry: &Registry) -> Self {
        Self {
            devices: registry
                .subjects
                .iter()
                .flat_map(|s| s.wears.iter())
                .map(|w| (w.device.0.clone(), w.kind))
                .collect(),
            cameras: registry.cameras.iter().map(|c| c.id.0.clone()).collect(),
            anchors: registry.anchors.iter().map(|a| a.id.0.clone()).collect(),
            antennas: registry.antennas.iter().map(|a| a.id.0.clone()).collect(),
            subjects: registry.subjects.iter().map(|s| s.id.0.clone()).collect(),
        }
    }
}

/// Which device kinds a message may refer to.
#[derive(Clone, Copy)]
enum Kinds {
    Imu,
    LocationTag,
    RssiTag,
    Any,
}

impl Kinds {
    fn accepts(self, kind: DeviceKind) -> bool {
        match self {
            Kinds::Imu => kind == DeviceKind::Imu,
            Kinds::LocationTag => kind == DeviceKind::UwbTag,
            Kinds::RssiTag => matches!(kind, DeviceKind::RfidTag | DeviceKind::BleTag),
            Kinds::Any => true,
        }
    }

    fn expected(self) -> &'static str {
        match self {
            Kinds::Imu => "imu",
            Kinds::LocationTag => "uwb_tag",
            Kinds::RssiTag => "rfid_tag or ble_tag",
            Kinds::Any => "any",
        }
    }
}

/// Identifies one time-ordered stream: message kind (its rank) and up to two interned ids plus a
/// track id. Built without allocating.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct StreamKey {
    rank: u8,
    a: u32,
    b: u32,
    track: u64,
}

/// The rank of a message kind, in `Message` declaration order (also the writer's tie-break).
pub(crate) fn type_rank(msg: &Message) -> u8 {
    match msg {
        Message::Skeleton(_) => 0,
        Message::Imu(_) => 1,
        Message::RtlsFix(_) => 2,
        Message::UwbRange(_) => 3,
        Message::Rssi(_) => 4,
        Message::Identified(_) => 5,
        Message::TagCorrection(_) => 6,
        Message::TruthSkeleton(_) => 7,
        Message::TruthTag(_) => 8,
    }
}

/// A checked message's time and the streams it is ordered in, to be recorded.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Times {
    t: SessionTime,
    source: StreamKey,
    camera: Option<StreamKey>,
}

impl Times {
    /// The message's time.
    pub(crate) fn t(&self) -> SessionTime {
        self.t
    }
}

/// Validates messages one by one and remembers what time order requires.
#[derive(Clone)]
pub(crate) struct Checker {
    ids: Option<IdIndex>,
    global_tolerance_ns: i64,
    names: HashMap<String, u32>,
    last: HashMap<StreamKey, SessionTime>,
    latest: Option<SessionTime>,
}

impl Checker {
    /// A checker with `registry` (or no id checks) and a global order tolerance.
    pub(crate) fn new(registry: Option<&Registry>, global_tolerance_ns: i64) -> Self {
        Self {
            ids: registry.map(IdIndex::new),
            global_tolerance_ns: global_tolerance_ns.max(0),
            names: HashMap::new(),
            last: HashMap::new(),
            latest: None,
        }
    }

    fn intern(&mut self, name: &str) -> u32 {
        if let Some(&i) = self.names.get(name) {
            return i;
        }
        let i = u32::try_from(self.names.len()).unwrap_or(u32::MAX);
        self.names.insert(name.to_owned(), i);
        i
    }

    /// Runs every check on `msg`; on success records its time, on failure changes nothing.
    pub(crate) fn check(&mut self, msg: &Message, file: &Arc<str>, line: u64) -> Result<()> {
        let times = self.check_unrecorded(msg, file, line)?;
        self.record(times);
        Ok(())
    }

    /// Whether a message at `t` would lead every message recorded so far by more than
    /// `max_jump_ns` (the first message always does): the reader then waits for the next one
    /// before recording it.
    pub(crate) fn leads(&self, t: SessionTime, max_jump_ns: i64) -> bool {
        self.latest
            .is_none_or(|latest| t.as_ns() > latest.as_ns().saturating_add(max_jump_ns))
    }

    /// The latest time recorded so far.
    pub(crate) fn latest(&self) -> Option<SessionTime> {
        self.latest
    }

    /// [`Checker::check`] without recording: the message's times, for [`Checker::record`].
    pub(crate) fn check_unrecorded(
        &mut self,
        msg: &Message,
        file: &Arc<str>,
        line: u64,
    ) -> Result<Times> {
        msg.validate().map_err(|source| RecordingError::Invalid {
            at: Pos::new(file, line),
            source,
        })?;
        if let Some(ids) = &self.ids {
            check_ids(ids, msg).map_err(|e| e.at(file, line))?;
        }
        self.check_order(msg, file, line)
    }

    /// Records a checked message's times: later messages are ordered after it.
    pub(crate) fn record(&mut self, times: Times) {
        let Times { t, source, camera } = times;
        self.last.insert(source, t);
        if let Some(camera) = camera {
            self.last.insert(camera, t);
        }
        self.latest = Some(self.latest.map_or(t, |l| l.max(t)));
    }

    /// The time-order part of [`Checker::check_unrecorded`].
    pub(crate) fn check_order(
        &mut self,
        msg: &Message,
        file: &Arc<str>,
        line: u64,
    ) -> Result<Times> {
        let t = msg.t();
        let rank = type_rank(msg);
        // The strict per-source stream and, for camera messages, the camera-level stream.
        let (source, camera) = match msg {
            Message::Skeleton(m) => self.camera_keys(rank, m.camera.as_str(), m.track.0),
            Message::Identified(m) => self.camera_keys(rank, m.camera.as_str(), m.track.0),
            Message::TruthSkeleton(m) => self.camera_keys(rank, m.camera.as_str(), m.track.0),
            Message::Imu(m) => (self.key(rank, m.device.as_str(), None), None),
            Message::RtlsFix(m) => (self.key(rank, m.tag.as_str(), None), None),
            Message::TagCorrection(m) => (self.key(rank, m.tag.as_str(), None), None),
            Message::TruthTag(m) => (self.key(rank, m.tag.as_str(), None), None),
            Message::UwbRange(m) => (
                self.key(rank, m.tag.as_str(), Some(m.anchor.as_str())),
                None,
            ),
            Message::Rssi(m) => (
                self.key(rank, m.tag.as_str(), Some(m.antenna.as_str())),
                None,
            ),
        };
        if let Some(&previous) = self.last.get(&source)
            && t <= previous
        {
            return Err(RecordingError::SourceOrder {
                at: Pos::new(file, line),
                t,
                previous,
                stream: stream_name(msg, false),
            });
        }
        if let Some(camera) = camera
            && let Some(&previous) = self.last.get(&camera)
            && t < previous
        {
            return Err(RecordingError::CameraOrder {
                at: Pos::new(file, line),
                t,
                previous,
                stream: stream_name(msg, true),
            });
        }
        if let Some(latest) = self.latest
            && t.as_ns() < latest.as_ns().saturating_sub(self.global_tolerance_ns)
        {
            return Err(RecordingError::GlobalOrder {
                at: Pos::new(file, line),
                t,
                latest,
                tolerance_ns: self.global_tolerance_ns,
            });
        }
        Ok(Times { t, source, camera })
    }

    fn key(&mut self, rank: u8, a: &str, b: Option<&str>) -> StreamKey {
        let a = self.intern(a);
        let b = b.map_or(u32::MAX, |b| self.intern(b));
        StreamKey {
            rank,
            a,
            b,
            track: 0,
        }
    }

    fn camera_keys(
        &mut self,
        rank: u8,
        camera: &str,
        track: u64,
    ) -> (StreamKey, Option<StreamKey>) {
        let a = self.intern(camera);
        let source = StreamKey {
            rank,
            a,
            b: 0,
            track,
        };
        // `b = 1` marks the camera-level stream; track is unused there.
        let camera = StreamKey {
            rank,
            a,
            b: 1,
            track: 0,
        };
        (source, Some(camera))
    }
}

/// The stream a message belongs to, in words, for error messages.
fn stream_name(msg: &Message, camera_level: bool) -> String {
    let camera_stream = |what: &str, camera: &str, track: u64| {
        if camera_level {
            format!("{what} of camera '{camera}'")
        } else {
            format!("{what} of camera '{camera}' track {track}")
        }
    };
    match msg {
        Message::Skeleton(m) => camera_stream("skeleton", m.camera.as_str(), m.track.0),
        Message::Identified(m) => {
            camera_stream("identified skeleton", m.camera.as_str(), m.track.0)
        }
        Message::TruthSkeleton(m) => camera_stream("truth skeleton", m.camera.as_str(), m.track.0),
        Message::Imu(m) => format!("imu sample of '{}'", m.device),
        Message::RtlsFix(m) => format!("rtls fix of tag '{}'", m.tag),
        Message::TagCorrection(m) => format!("tag correction of tag '{}'", m.tag),
        Message::TruthTag(m) => format!("truth of tag '{}'", m.tag),
        Message::UwbRange(m) => format!("uwb range of tag '{}' to anchor '{}'", m.tag, m.anchor),
        Message::Rssi(m) => format!("rssi read of tag '{}' at antenna '{}'", m.tag, m.antenna),
    }
}

/// An id problem before its position is known.
enum IdProblem {
    Unknown(&'static str, String),
    WrongKind(&'static str, String, DeviceKind, Kinds),
}

impl IdProblem {
    fn at(self, file: &Arc<str>, line: u64) -> RecordingError {
        let at = Pos::new(file, line);
        match self {
            IdProblem::Unknown(what, id) => RecordingError::UnknownId { at, what, id },
            IdProblem::WrongKind(what, id, kind, kinds) => RecordingError::WrongDeviceKind {
                at,
                what,
                id,
                kind,
                expected: kinds.expected(),
            },
        }
    }
}

fn device(
    ids: &IdIndex,
    what: &'static str,
    id: &str,
    kinds: Kinds,
) -> std::result::Result<(), IdProblem> {
    match ids.devices.get(id) {
        None => Err(IdProblem::Unknown(what, id.to_owned())),
        Some(&kind) if !kinds.accepts(kind) => {
            Err(IdProblem::WrongKind(what, id.to_owned(), kind, kinds))
        }
        Some(_) => Ok(()),
    }
}

fn member(
    set: &HashSet<String>,
    what: &'static str,
    id: &str,
) -> std::result::Result<(), IdProblem> {
    if set.contains(id) {
        Ok(())
    } else {
        Err(IdProblem::Unknown(what, id.to_owned()))
    }
}

fn check_ids(ids: &IdIndex, msg: &Message) -> std::result::Result<(), IdProblem> {
    match msg {
        Message::Skeleton(m) => member(&ids.cameras, "camera", m.camera.as_str()),
        Message::Imu(m) => device(ids, "imu device", m.device.as_str(), Kinds::Imu),
        Message::RtlsFix(m) => device(ids, "rtls tag", m.tag.as_str(), Kinds::LocationTag),
        Message::UwbRange(m) => {
            device(ids, "uwb tag", m.tag.as_str(), Kinds::LocationTag)?;
            member(&ids.anchors, "uwb anchor", m.anchor.as_str())
        }
        Message::Rssi(m) => {
            device(ids, "rssi tag", m.tag.as_str(), Kinds::RssiTag)?;
            member(&ids.antennas, "rssi antenna", m.antenna.as_str())
        }
        Message::Identified(m) => {
            member(&ids.cameras, "camera", m.camera.as_str())?;
            if let Some(s) = m.identity.subject() {
                member(&ids.subjects, "subject", s.as_str())?;
            }
            for e in &m.evidence {
                device(ids, "evidence device", e.device.as_str(), Kinds::Any)?;
            }
            if let Some(d) = &m.decision {
                for c in d.named.iter().chain(&d.runner_up) {
                    member(&ids.subjects, "decision subject", c.subject.as_str())?;
                }
            }
            Ok(())
        }
        Message::TagCorrection(m) => device(ids, "rtls tag", m.tag.as_str(), Kinds::LocationTag),
        Message::TruthSkeleton(m) => {
            member(&ids.cameras, "camera", m.camera.as_str())?;
            if let Some(s) = &m.subject {
                member(&ids.subjects, "subject", s.as_str())?;
            }
            Ok(())
        }
        Message::TruthTag(m) => device(ids, "tag", m.tag.as_str(), Kinds::Any),
    }
}
