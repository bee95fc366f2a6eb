//! Events derived from the decision stream, published on [`crate::topics::EVENT_TOPIC`], per
//! subject and camera: a subject named for the first time on a camera, named there again on
//! another track (re-identified), lost to it (no decision of that camera names him for
//! `lost_after_s` of session time), and warnings.

use nomen_core::{CameraId, IdentifiedSkeleton, SubjectId, TrackId};
use serde::Serialize;
use std::collections::BTreeMap;

/// What happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EventKind {
    /// A subject is named for the first time in the session by a camera.
    Named,
    /// A subject is named on another track of a camera than the one he had there, or after he
    /// was lost to it.
    ReIdentified,
    /// No decision of a camera has named a subject for `lost_after_s`.
    Lost,
    /// Something an operator should know (a registry refused, the engine's warnings).
    Warning,
}

/// One event.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Event {
    /// Session time, ns (for a warning without a time, the newest seen).
    pub t_ns: i64,
    /// What happened.
    pub kind: EventKind,
    /// The subject, for named, re-identified and lost.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub subject: Option<SubjectId>,
    /// The camera of the track he is (or was last) named on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraId>,
    /// The track.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub track: Option<TrackId>,
    /// The decision's confidence (named, re-identified).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f64>,
    /// A sentence for people.
    pub message: String,
}

impl Event {
    /// A warning at `t_ns`.
    pub fn warning(t_ns: i64, message: impl Into<String>) -> Self {
        Event {
            t_ns,
            kind: EventKind::Warning,
            subject: None,
            camera: None,
            track: None,
            confidence: None,
            message: message.into(),
        }
    }
}

#[derive(Debug)]
struct Seen {
    track: TrackId,
    last_t_ns: i64,
    is_lost: bool,
}

/// Follows who is named where and turns the decisions into events. Holds one entry per
/// subject and camera named in the session (the registry bounds them).
#[derive(Debug)]
pub struct Events {
    lost_after_ns: i64,
    subjects: BTreeMap<(SubjectId, CameraId), Seen>,
}

impl Events {
    /// Events that call a subject lost after `lost_after_s` without a decision naming him.
    pub fn new(lost_after_s: f64) -> Self {
        Events {
            lost_after_ns: (lost_after_s * 1e9) as i64,
            subjects: BTreeMap::new(),
        }
    }

    /// The events a decision makes (none when it names nobody or the same track again).
    pub fn on_decision(&mut self, d: &IdentifiedSkeleton, out: &mut Vec<Event>) {
        let Some(subject) = d.identity.subject() else {
            return;
        };
        let t_ns = d.t.as_ns();
        let event = |kind, message| Event {
            t_ns,
            kind,
            subject: Some(subject.clone()),
            camera: Some(d.camera.clone()),
            track: Some(d.track),
            confidence: Some(d.confidence),
            message,
        };
        match self.subjects.get_mut(&(subject.clone(), d.camera.clone())) {
            None => {
                out.push(event(
                    EventKind::Named,
                    format!("{subject} named on {} track {}", d.camera, d.track),
                ));
                self.subjects.insert(
                    (subject.clone(), d.camera.clone()),
                    Seen {
                        track: d.track,
                        last_t_ns: t_ns,
                        is_lost: false,
                    },
                );
            }
            Some(seen) => {
                if seen.is_lost || seen.track != d.track {
                    out.push(event(
                        EventKind::ReIdentified,
                        format!(
                            "{subject} named on {} track {} (was track {}{})",
                            d.camera,
                            d.track,
                            seen.track,
                            if seen.is_lost { ", lost" } else { "" }
                        ),
                    ));
                    seen.track = d.track;
                    seen.is_lost = false;
                }
                seen.last_t_ns = seen.last_t_ns.max(t_ns);
            }
        }
    }

    /// The subjects lost by session time `now_ns`.
    pub fn on_time(&mut self, now_ns: i64, out: &mut Vec<Event>) {
        for ((subject, camera), seen) in &mut self.subjects {
            if !seen.is_lost && now_ns.saturating_sub(seen.last_t_ns) > self.lost_after_ns {
                seen.is_lost = true;
                out.push(Event {
                    t_ns: now_ns,
                    kind: EventKind::Lost,
                    subject: Some(subject.clone()),
                    camera: Some(camera.clone()),
                    track: Some(seen.track),
                    confidence: None,
                    message: format!(
                        "{subject} lost to {camera}: last named on track {} {:.1} s ago",
                        seen.track,
                        (now_ns - seen.last_t_ns) as f64 * 1e-9
                    ),
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_core::skeleton::Joints;
    use nomen_core::{Identity, SessionTime};

    fn decision(t_s: f64, track: u64, who: Option<&str>) -> IdentifiedSkeleton {
        decision_on("cam", t_s, track, who)
    }

    fn decision_on(camera: &str, t_s: f64, track: u64, who: Option<&str>) -> IdentifiedSkeleton {
        IdentifiedSkeleton {
            t: SessionTime::from_ns((t_s * 1e9) as i64),
            camera: CameraId::new(camera),
            track: TrackId(track),
            identity: who.map_or(Identity::Anonymous, |s| {
                Identity::Subject(SubjectId::new(s))
            }),
            confidence: 0.9,
            evidence: Vec::new(),
            decision: None,
            joints: Joints::new(),
        }
    }

    #[test]
    fn a_subject_is_named_once_then_reidentified_on_a_new_track() {
        let mut events = Events::new(2.0);
        let mut out = Vec::new();
        events.on_decision(&decision(0.0, 1, None), &mut out);
        assert!(out.is_empty());
        events.on_decision(&decision(0.5, 1, Some("ana")), &mut out);
        events.on_decision(&decision(1.0, 1, Some("ana")), &mut out);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].kind, EventKind::Named);
        events.on_decision(&decision(1.5, 7, Some("ana")), &mut out);
        assert_eq!(out[1].kind, EventKind::ReIdentified);
        assert_eq!(out[1].track, Some(TrackId(7)));
    }

    #[test]
    fn a_subject_seen_by_two_cameras_is_named_once_by_each_and_not_reidentified_between_them() {
        let mut events = Events::new(2.0);
        let mut out = Vec::new();
        for i in 0..10 {
            let t = f64::from(i) * 0.1;
            events.on_decision(&decision_on("front", t, 1, Some("ana")), &mut out);
            events.on_decision(&decision_on("side", t, 5, Some("ana")), &mut out);
        }
        assert_eq!(out.len(), 2);
        assert!(out.iter().all(|e| e.kind == EventKind::Named));
    }

    #[test]
    fn a_subject_nobody_names_for_long_enough_is_lost_then_found() {
        let mut events = Events::new(2.0);
        let mut out = Vec::new();
        events.on_decision(&decision(1.0, 1, Some("ana")), &mut out);
        events.on_time(2_900_000_000, &mut out);
        assert_eq!(out.len(), 1);
        events.on_time(3_100_000_000, &mut out);
        assert_eq!(out[1].kind, EventKind::Lost);
        events.on_time(9_000_000_000, &mut out);
        assert_eq!(out.len(), 2, "lost once");
        events.on_decision(&decision(9.0, 1, Some("ana")), &mut out);
        assert_eq!(out[2].kind, EventKind::ReIdentified);
    }
}
