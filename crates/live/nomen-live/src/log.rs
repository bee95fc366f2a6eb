//! The identity log: every decision and event of `nomen serve` in an SQLite file (WAL), written
//! before it is published, so that the log holds every decision a subscriber may have seen even
//! after `kill -9`. `docs/live.md` documents the schema; [`query`] reads it back.

use crate::events::Event;
use crate::session::Output;
use crate::{LiveError, Result};
use nomen_core::skeleton::Joints;
use nomen_core::{JointObservation, Message, Registry, SkeletonObservation};
use rusqlite::{Connection, OptionalExtension, params};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS registries (
    id INTEGER PRIMARY KEY,
    registry_json TEXT NOT NULL UNIQUE
);
CREATE TABLE IF NOT EXISTS sessions (
    id INTEGER PRIMARY KEY,
    registry_id INTEGER NOT NULL REFERENCES registries(id),
    started_unix_ms INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS decisions (
    id INTEGER PRIMARY KEY,
    session_id INTEGER NOT NULL REFERENCES sessions(id),
    t_ns INTEGER NOT NULL,
    camera TEXT NOT NULL,
    track INTEGER NOT NULL,
    subject TEXT,
    confidence REAL NOT NULL,
    x_m REAL, y_m REAL, z_m REAL,
    evidence_json TEXT NOT NULL,
    decision_json TEXT
);
CREATE INDEX IF NOT EXISTS decisions_by_subject ON decisions(subject, t_ns);
CREATE INDEX IF NOT EXISTS decisions_by_time ON decisions(t_ns);
CREATE TABLE IF NOT EXISTS tag_corrections (
    id INTEGER PRIMARY KEY,
    session_id INTEGER NOT NULL REFERENCES sessions(id),
    t_ns INTEGER NOT NULL,
    tag TEXT NOT NULL,
    raw_x_m REAL NOT NULL, raw_y_m REAL NOT NULL, raw_z_m REAL NOT NULL,
    x_m REAL NOT NULL, y_m REAL NOT NULL, z_m REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS events (
    id INTEGER PRIMARY KEY,
    session_id INTEGER REFERENCES sessions(id),
    t_ns INTEGER NOT NULL,
    kind TEXT NOT NULL,
    subject TEXT,
    camera TEXT,
    track INTEGER,
    confidence REAL,
    message TEXT NOT NULL
);
";

fn sql_error(path: &str) -> impl Fn(rusqlite::Error) -> LiveError + '_ {
    move |e| LiveError::Log {
        path: path.to_owned(),
        why: e.to_string(),
    }
}

/// How long the positions of observed skeletons are kept for their decisions, s of session
/// time (a decision comes out at most the engine's worst-case latency, a few seconds, after its
/// observation).
const POSITION_MEMORY_S: f64 = 30.0;

/// An open identity log.
pub struct IdentityLog {
    path: String,
    connection: Connection,
    session_id: Option<i64>,
    /// (t_ns, camera, track) → mean joint position of the observed skeleton, for decisions
    /// whose joints are not filled (without pose refinement they carry none).
    positions: BTreeMap<(i64, String, u64), [f64; 3]>,
}

fn mean_position(joints: &Joints<JointObservation>) -> Option<[f64; 3]> {
    let (mut sum, mut n) = ([0.0f64; 3], 0u32);
    for (_, j) in joints.iter() {
        sum[0] += j.position_m.x;
        sum[1] += j.position_m.y;
        sum[2] += j.position_m.z;
        n += 1;
    }
    (n > 0).then(|| sum.map(|s| s / f64::from(n)))
}

impl IdentityLog {
    /// Opens (or creates) the log at `path`, in WAL mode.
    pub fn open(path: &Path) -> Result<Self> {
        let name = path.display().to_string();
        let connection = Connection::open(path).map_err(sql_error(&name))?;
        // WAL: a reader (`nomen log query`) never blocks the service. NORMAL: a commit is in
        // the WAL file when it returns, which survives the process being killed (not a power
        // cut, which may lose the last commits).
        connection
            .execute_batch("PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;")
            .map_err(sql_error(&name))?;
        connection.execute_batch(SCHEMA).map_err(sql_error(&name))?;
        Ok(IdentityLog {
            path: name,
            connection,
            session_id: None,
            positions: BTreeMap::new(),
        })
    }

    /// Starts a session on `registry` at wall time `unix_ms`; the registry is stored once.
    pub fn begin_session(&mut self, registry: &Registry, unix_ms: i64) -> Result<()> {
        let json = serde_json::to_string(registry).unwrap_or_default();
        let tx = self
            .connection
            .transaction()
            .map_err(sql_error(&self.path))?;
        tx.execute(
            "INSERT OR IGNORE INTO registries (registry_json) VALUES (?1)",
            params![json],
        )
        .map_err(sql_error(&self.path))?;
        let registry_id: i64 = tx
            .query_row(
                "SELECT id FROM registries WHERE registry_json = ?1",
                params![json],
                |row| row.get(0),
            )
            .map_err(sql_error(&self.path))?;
        tx.execute(
            "INSERT INTO sessions (registry_id, started_unix_ms) VALUES (?1, ?2)",
            params![registry_id, unix_ms],
        )
        .map_err(sql_error(&self.path))?;
        self.session_id = Some(tx.last_insert_rowid());
        tx.commit().map_err(sql_error(&self.path))
    }

    /// A skeleton the engine took: its position is logged with its decision.
    pub fn observe(&mut self, s: &SkeletonObservation) {
        let t_ns = s.t.as_ns();
        if let Some(p) = mean_position(&s.joints) {
            self.positions
                .insert((t_ns, s.camera.as_str().to_owned(), s.track.0), p);
        }
        let oldest = t_ns.saturating_sub((POSITION_MEMORY_S * 1e9) as i64);
        while let Some(entry) = self.positions.first_entry() {
            if entry.key().0 >= oldest {
                break;
            }
            entry.remove();
        }
    }

    /// Writes a batch of outputs in one transaction.
    pub fn write(&mut self, outputs: &[Output]) -> Result<()> {
        let session = self.session_id;
        let tx = self
            .connection
            .transaction()
            .map_err(sql_error(&self.path))?;
        for output in outputs {
            match output {
                Output::Decision(Message::Identified(d)) => {
                    let mean = mean_position(&d.joints).or_else(|| {
                        self.positions
                            .get(&(d.t.as_ns(), d.camera.as_str().to_owned(), d.track.0))
                            .copied()
                    });
                    tx.execute(
                        "INSERT INTO decisions (session_id, t_ns, camera, track, subject, \
                         confidence, x_m, y_m, z_m, evidence_json, decision_json) \
                         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)",
                        params![
                            session,
                            d.t.as_ns(),
                            d.camera.as_str(),
                            i64::try_from(d.track.0).unwrap_or(i64::MAX),
                            d.identity.subject().map(|s| s.as_str()),
                            d.confidence,
                            mean.map(|m| m[0]),
                            mean.map(|m| m[1]),
                            mean.map(|m| m[2]),
                            serde_json::to_string(&d.evidence).unwrap_or_default(),
                            d.decision
                                .as_ref()
                                .and_then(|trace| serde_json::to_string(trace).ok()),
                        ],
                    )
                    .map_err(sql_error(&self.path))?;
                }
                Output::Decision(Message::TagCorrection(c)) => {
                    tx.execute(
                        "INSERT INTO tag_corrections (session_id, t_ns, tag, raw_x_m, raw_y_m, \
                         raw_z_m, x_m, y_m, z_m) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
                        params![
                            session,
                            c.t.as_ns(),
                            c.tag.as_str(),
                            c.raw_position_m.x,
                            c.raw_position_m.y,
                            c.raw_position_m.z,
                            c.corrected_position_m.x,
                            c.corrected_position_m.y,
                            c.corrected_position_m.z,
                        ],
                    )
                    .map_err(sql_error(&self.path))?;
                }
                Output::Decision(_) => {}
                Output::Event(e) => insert_event(&tx, session, e).map_err(sql_error(&self.path))?,
            }
        }
        tx.commit().map_err(sql_error(&self.path))
    }
}

fn insert_event(
    tx: &rusqlite::Transaction<'_>,
    session: Option<i64>,
    e: &Event,
) -> rusqlite::Result<()> {
    let kind = serde_json::to_value(e.kind)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_default();
    tx.execute(
        "INSERT INTO events (session_id, t_ns, kind, subject, camera, track, confidence, message) \
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
        params![
            session,
            e.t_ns,
            kind,
            e.subject.as_ref().map(|s| s.as_str()),
            e.camera.as_ref().map(|c| c.as_str()),
            e.track.map(|t| i64::try_from(t.0).unwrap_or(i64::MAX)),
            e.confidence,
            e.message,
        ],
    )
    .map(drop)
}

/// Which rows [`query`] returns.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Query {
    /// Only decisions naming this subject (`Some("")`: only anonymous ones).
    pub subject: Option<String>,
    /// Only this camera.
    pub camera: Option<String>,
    /// From this session time, ns (inclusive).
    pub from_ns: Option<i64>,
    /// Until this session time, ns (inclusive).
    pub to_ns: Option<i64>,
    /// Only this session (default: every session).
    pub session: Option<i64>,
}

/// A decision as the log holds it: who was where, when, and why he was named.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoggedDecision {
    /// The session.
    pub session: i64,
    /// Session time of the observation, ns.
    pub t_ns: i64,
    /// Camera.
    pub camera: String,
    /// Track.
    pub track: i64,
    /// The subject named, or none (anonymous).
    pub subject: Option<String>,
    /// The probability that the identity is right.
    pub confidence: f64,
    /// Mean of the skeleton's joint positions in the camera frame, m.
    pub position_m: Option<[f64; 3]>,
    /// The evidence behind the decision (modality, device, score), as JSON.
    pub evidence: serde_json::Value,
    /// Why the identity was given (`nomen_core::DecisionTrace`: rule, decision time, named and
    /// runner-up subjects with their scores), as JSON; null when the producer gave none.
    pub decision: serde_json::Value,
}

/// The decisions in the log at `path` that `q` selects, in session and time order.
pub fn query(path: &Path, q: &Query) -> Result<Vec<LoggedDecision>> {
    let name = path.display().to_string();
    if !path.is_file() {
        return Err(LiveError::Log {
            path: name,
            why: "no such file".to_owned(),
        });
    }
    let connection = Connection::open_with_flags(path, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
        .map_err(sql_error(&name))?;
    let has_table: Option<String> = connection
        .query_row(
            "SELECT name FROM sqlite_master WHERE type='table' AND name='decisions'",
            [],
            |row| row.get(0),
        )
        .optional()
        .map_err(sql_error(&name))?;
    if has_table.is_none() {
        return Err(LiveError::Log {
            path: name,
            why: "not an identity log (no decisions table)".to_owned(),
        });
    }
    let mut statement = connection
        .prepare(
            "SELECT session_id, t_ns, camera, track, subject, confidence, x_m, y_m, z_m, \
             evidence_json, decision_json FROM decisions \
             WHERE (?1 IS NULL OR (?1 = '' AND subject IS NULL) OR subject = ?1) \
             AND (?2 IS NULL OR camera = ?2) AND (?3 IS NULL OR t_ns >= ?3) \
             AND (?4 IS NULL OR t_ns <= ?4) AND (?5 IS NULL OR session_id = ?5) \
             ORDER BY session_id, t_ns, camera, track",
        )
        .map_err(sql_error(&name))?;
    let rows = statement
        .query_map(
            params![q.subject, q.camera, q.from_ns, q.to_ns, q.session],
            |row| {
                let x: Option<f64> = row.get(6)?;
                let y: Option<f64> = row.get(7)?;
                let z: Option<f64> = row.get(8)?;
                let evidence: String = row.get(9)?;
                let decision: Option<String> = row.get(10)?;
                Ok(LoggedDecision {
                    session: row.get(0)?,
                    t_ns: row.get(1)?,
                    camera: row.get(2)?,
                    track: row.get(3)?,
                    subject: row.get(4)?,
                    confidence: row.get(5)?,
                    position_m: match (x, y, z) {
                        (Some(x), Some(y), Some(z)) => Some([x, y, z]),
                        _ => None,
                    },
                    evidence: serde_json::from_str(&evidence).unwrap_or_default(),
                    decision: decision
                        .and_then(|d| serde_json::from_str(&d).ok())
                        .unwrap_or_default(),
                })
            },
        )
        .map_err(sql_error(&name))?;
    rows.collect::<rusqlite::Result<Vec<_>>>()
        .map_err(sql_error(&name))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::Event;
    use nalgebra::Point3;
    use nomen_core::{
        CameraId, DeviceId, Evidence, IdentifiedSkeleton, Identity, Joint, JointObservation,
        SessionTime, SubjectId, TrackId,
    };

    fn decision(t_ns: i64, who: Option<&str>) -> Output {
        let mut joints = Joints::new();
        if t_ns > 1 {
            joints.insert(
                Joint::Pelvis,
                JointObservation::tracked(Point3::new(1.0, 2.0, 3.0)),
            );
        }
        Output::Decision(Message::Identified(Box::new(IdentifiedSkeleton {
            t: SessionTime::from_ns(t_ns),
            camera: CameraId::new("cam"),
            track: TrackId(4),
            identity: who.map_or(Identity::Anonymous, |s| {
                Identity::Subject(SubjectId::new(s))
            }),
            confidence: 0.8,
            decision: None,
            evidence: vec![Evidence {
                modality: "imu".to_owned(),
                device: DeviceId::new("w1"),
                score: 0.7,
            }],
            joints,
        })))
    }

    #[test]
    fn decisions_come_back_with_where_and_why() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.sqlite");
        let mut log = IdentityLog::open(&path).unwrap();
        log.begin_session(&Registry::default(), 0).unwrap();
        // Without joints of its own, a decision takes its observation's position.
        let mut joints = Joints::new();
        joints.insert(
            Joint::Pelvis,
            JointObservation::tracked(Point3::new(5.0, 0.0, 1.0)),
        );
        log.observe(&SkeletonObservation {
            t: SessionTime::from_ns(1),
            camera: CameraId::new("cam"),
            track: TrackId(4),
            joints,
        });
        log.write(&[
            decision(1, None),
            decision(2, Some("ana")),
            Output::Event(Event::warning(2, "w")),
        ])
        .unwrap();
        let all = query(&path, &Query::default()).unwrap();
        assert_eq!(all.len(), 2);
        let ana = query(
            &path,
            &Query {
                subject: Some("ana".to_owned()),
                ..Query::default()
            },
        )
        .unwrap();
        assert_eq!(ana.len(), 1);
        assert_eq!(ana[0].position_m, Some([1.0, 2.0, 3.0]));
        assert_eq!(ana[0].evidence[0]["device"], "w1");
        let anonymous = query(
            &path,
            &Query {
                subject: Some(String::new()),
                ..Query::default()
            },
        )
        .unwrap();
        assert_eq!(anonymous[0].t_ns, 1);
        assert_eq!(anonymous[0].position_m, Some([5.0, 0.0, 1.0]));
    }

    #[test]
    fn a_second_session_on_the_same_registry_stores_it_once() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.sqlite");
        let mut log = IdentityLog::open(&path).unwrap();
        log.begin_session(&Registry::default(), 0).unwrap();
        log.begin_session(&Registry::default(), 1).unwrap();
        let n: i64 = log
            .connection
            .query_row("SELECT COUNT(*) FROM registries", [], |r| r.get(0))
            .unwrap();
        assert_eq!(n, 1);
        assert!(query(&dir.path().join("none"), &Query::default()).is_err());
    }
}
