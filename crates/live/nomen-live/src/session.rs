//! The session: one engine per registry, fed messages in arrival order, told when time passes
//! without any, its decisions turned into outputs and events. Sans-IO: the wall clock comes in
//! as an argument.

use crate::events::{Event, Events};
use nomen_core::{Message, Registry, SessionTime};
use nomen_engine::Engine;
use std::time::{Duration, Instant};

/// Makes the engine of a session from a registry as it came (the CLI's, shared with
/// `nomen run`); returns the registry the engine runs on (the one given, or that one with a
/// calibration laid over it) beside the engine.
pub type EngineFactory = Box<dyn FnMut(Registry) -> Result<(Registry, Engine), String> + Send>;

/// How long no message may arrive before the engine is told that time passes (as
/// `nomen run --live` does).
pub const IDLE_TICK: Duration = Duration::from_millis(100);

/// Settings of a session.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SessionOptions {
    /// The most session time an idle tick moves the clock past the newest message, ns: far
    /// enough for every decision to come out, never a time jump (the CLI computes it from the
    /// engine configuration, as for `nomen run --live`).
    pub max_idle_ns: i64,
    /// See [`crate::ServeConfig::lost_after_s`].
    pub lost_after_s: f64,
}

/// What a session produces.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    /// An engine output (identified skeleton or tag correction), in time order within a batch.
    Decision(Message),
    /// An event.
    Event(Event),
}

/// Why a message was not taken.
#[derive(Debug, Clone, PartialEq)]
pub enum Refusal {
    /// No registry yet: no engine to take it.
    NoRegistry,
    /// The engine refused it; the engine's reason.
    Engine(String),
}

struct Current {
    /// The registry as it came (a message or the command's file): a registry equal to it
    /// changes nothing.
    received: Registry,
    /// The registry the engine runs on: what is logged, recorded and shown.
    registry: Registry,
    engine: Engine,
    events: Events,
}

/// The engine's session, with the state the live loop needs around it.
pub struct Session {
    make_engine: EngineFactory,
    options: SessionOptions,
    current: Option<Current>,
    num_sessions: u64,
    newest: Option<(SessionTime, Instant)>,
    batch: Vec<Message>,
    events: Vec<Event>,
}

impl Session {
    /// A session that makes its engines with `make_engine`; it has no registry yet.
    pub fn new(make_engine: EngineFactory, options: SessionOptions) -> Self {
        Session {
            make_engine,
            options,
            current: None,
            num_sessions: 0,
            newest: None,
            batch: Vec::new(),
            events: Vec::new(),
        }
    }

    /// Sessions started so far (one per registry).
    pub fn num_sessions(&self) -> u64 {
        self.num_sessions
    }

    /// The registry the current engine runs on (calibrated, when the factory calibrates).
    pub fn registry(&self) -> Option<&Registry> {
        self.current.as_ref().map(|c| &c.registry)
    }

    /// The session time of the newest message the engine took, ns (0 before any).
    pub fn newest_ns(&self) -> i64 {
        self.newest.map_or(0, |(t, _)| t.as_ns())
    }

    /// The engine's statistics, when there is a session.
    pub fn engine_stats(&self) -> Option<&nomen_engine::EngineStats> {
        self.current.as_ref().map(|c| c.engine.stats())
    }

    /// A registry arrived. The same as the current one came changes nothing; another
    /// finishes the current session (its last decisions go to `out`) and starts a new one. A
    /// registry the engine refuses leaves the current session as it was and is reported as a
    /// warning.
    pub fn set_registry(&mut self, received: Registry, out: &mut Vec<Output>) {
        if self
            .current
            .as_ref()
            .is_some_and(|c| c.received == received)
        {
            return;
        }
        let t_ns = self.newest.map_or(0, |(t, _)| t.as_ns());
        match (self.make_engine)(received.clone()) {
            Ok((registry, engine)) => {
                self.finish(out);
                self.num_sessions += 1;
                self.newest = None;
                self.current = Some(Current {
                    received,
                    registry,
                    engine,
                    events: Events::new(self.options.lost_after_s),
                });
            }
            Err(why) => out.push(Output::Event(Event::warning(
                t_ns,
                format!("registry refused, the session goes on with the one it had: {why}"),
            ))),
        }
    }

    /// A message arrived at wall time `now`: it goes to the engine, the decisions then final go
    /// to `out`.
    pub fn push(
        &mut self,
        msg: &Message,
        now: Instant,
        out: &mut Vec<Output>,
    ) -> Result<(), Refusal> {
        let Some(current) = self.current.as_mut() else {
            return Err(Refusal::NoRegistry);
        };
        let pushed = current
            .engine
            .push(msg)
            .map_err(|e| Refusal::Engine(e.to_string()));
        // Only a message the engine took moves the clock the idle path runs on: one refused
        // for a time jump must not hold it hours ahead.
        if pushed.is_ok() && self.newest.is_none_or(|(t, _)| msg.t() > t) {
            self.newest = Some((msg.t(), now));
        }
        self.poll(out);
        pushed
    }

    /// No message arrived for a while (at least [`IDLE_TICK`]): the engine is told that the
    /// session clock ran on with the wall clock since the newest message (at most
    /// [`SessionOptions::max_idle_ns`]), and the decisions then final go to `out`.
    pub fn idle(&mut self, now: Instant, out: &mut Vec<Output>) {
        let (Some(current), Some((newest, at))) = (self.current.as_mut(), self.newest) else {
            return;
        };
        let idle_ns =
            i64::try_from(now.saturating_duration_since(at).as_nanos()).unwrap_or(i64::MAX);
        let t = newest
            .as_ns()
            .saturating_add(idle_ns.min(self.options.max_idle_ns));
        // Within the time-jump bound by construction; a refusal changes nothing.
        let _ = current.engine.advance_to(SessionTime::from_ns(t));
        self.poll(out);
    }

    /// Ends the session: every decision still held goes to `out`, then the engine's warnings.
    /// The registry is kept, so later messages start a new engine with it.
    pub fn finish(&mut self, out: &mut Vec<Output>) {
        let Some(mut current) = self.current.take() else {
            return;
        };
        current.engine.finish(&mut self.batch);
        self.emit(&mut current, out);
        let t_ns = self.newest.map_or(0, |(t, _)| t.as_ns());
        let stats = current.engine.stats();
        if let Some(why) = &stats.first_message_dropped {
            out.push(Output::Event(Event::warning(
                t_ns,
                format!("the session's first message was dropped: {why}"),
            )));
        }
        for (device, g) in stats.implausible_gravity() {
            out.push(Output::Event(Event::warning(
                t_ns,
                format!(
                    "imu {device} started from {g:.3} m/s² of gravity (about 9.81 expected): \
                     are its accelerations in g or milli-g?"
                ),
            )));
        }
        // A finished engine takes nothing more: the next message needs a fresh one.
        match (self.make_engine)(current.received.clone()) {
            Ok((registry, engine)) => {
                self.current = Some(Current {
                    received: current.received,
                    registry,
                    engine,
                    events: Events::new(self.options.lost_after_s),
                });
            }
            Err(why) => out.push(Output::Event(Event::warning(t_ns, why))),
        }
    }

    fn poll(&mut self, out: &mut Vec<Output>) {
        let Some(mut current) = self.current.take() else {
            return;
        };
        current.engine.poll(&mut self.batch);
        self.emit(&mut current, out);
        self.current = Some(current);
    }

    fn emit(&mut self, current: &mut Current, out: &mut Vec<Output>) {
        if self.batch.is_empty() {
            return;
        }
        self.batch.sort_by_key(|m| m.t());
        let mut last_ns = i64::MIN;
        for m in self.batch.drain(..) {
            if let Message::Identified(d) = &m {
                current.events.on_decision(d, &mut self.events);
            }
            last_ns = last_ns.max(m.t().as_ns());
            out.push(Output::Decision(m));
        }
        current.events.on_time(last_ns, &mut self.events);
        out.extend(self.events.drain(..).map(Output::Event));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use nomen_core::skeleton::Joints;
    use nomen_core::{CameraId, Joint, JointObservation, SkeletonObservation, TrackId};
    use nomen_engine::EngineConfig;

    /// One person standing before camera `cam` at `t_s`.
    fn skeleton(t_s: f64) -> Message {
        let mut joints = Joints::new();
        for (i, joint) in Joint::ALL.iter().enumerate() {
            let position = Point3::new(1.0, 2.0, 0.1 * i as f64);
            joints.insert(*joint, JointObservation::tracked(position));
        }
        Message::from(SkeletonObservation {
            t: SessionTime::from_ns((t_s * 1e9) as i64),
            camera: CameraId::new("cam"),
            track: TrackId(1),
            joints,
        })
    }

    /// A factory of default engines on `calibrate(registry)`.
    fn factory(calibrate: fn(Registry) -> Registry) -> EngineFactory {
        Box::new(move |registry: Registry| {
            let registry = calibrate(registry);
            Engine::new(registry.clone(), EngineConfig::default())
                .map(|engine| (registry, engine))
                .map_err(|e| e.to_string())
        })
    }

    const OPTIONS: SessionOptions = SessionOptions {
        max_idle_ns: 10_000_000_000,
        lost_after_s: 3.0,
    };

    fn num_decisions(out: &[Output]) -> usize {
        out.iter()
            .filter(|o| matches!(o, Output::Decision(Message::Identified(_))))
            .count()
    }

    #[test]
    fn a_refused_time_jump_does_not_hold_the_idle_clock_ahead() {
        let registry: Registry = serde_json::from_str(r#"{"cameras":[{"id":"cam"}]}"#).unwrap();
        let mut session = Session::new(factory(|registry| registry), OPTIONS);
        let mut out = Vec::new();
        session.set_registry(registry, &mut out);
        let start = Instant::now();
        let num_frames = 150;
        for k in 0..num_frames {
            let pushed = session.push(&skeleton(1.0 + f64::from(k) / 30.0), start, &mut out);
            assert!(pushed.is_ok(), "{pushed:?}");
        }
        // A frame stamped two hours ahead is refused as a time jump.
        assert!(session.push(&skeleton(7200.0), start, &mut out).is_err());
        assert!(num_decisions(&out) < num_frames as usize);
        // Ten seconds without a message: the clock runs on from the newest frame taken, and
        // every frame is decided.
        session.idle(start + Duration::from_secs(10), &mut out);
        assert_eq!(num_decisions(&out), num_frames as usize);
    }

    #[test]
    fn the_session_runs_on_the_registry_the_factory_made_and_takes_the_same_one_again_as_no_change()
    {
        let received: Registry = serde_json::from_str(r#"{"cameras":[{"id":"cam"}]}"#).unwrap();
        // A factory that lays a calibration over what it is given (the camera's scale).
        let mut session = Session::new(
            factory(|mut registry| {
                for camera in &mut registry.cameras {
                    camera.scale = 0.01;
                }
                registry
            }),
            OPTIONS,
        );
        let mut out = Vec::new();
        session.set_registry(received.clone(), &mut out);
        assert_eq!(session.num_sessions(), 1);
        let used = session.registry().unwrap();
        assert_ne!(used, &received);
        assert!(used.cameras.iter().all(|c| c.scale == 0.01));
        // The same registry again (a retained message, or the file's on MQTT) is no change.
        session.set_registry(received.clone(), &mut out);
        assert_eq!(session.num_sessions(), 1);
        // A finished session goes on with an engine on the calibrated registry.
        session.finish(&mut out);
        assert!(
            session
                .registry()
                .unwrap()
                .cameras
                .iter()
                .all(|c| c.scale == 0.01)
        );
        // Another registry is a new session.
        let mut other = received;
        other.cameras[0].id = nomen_core::CameraId::new("door");
        session.set_registry(other, &mut out);
        assert_eq!(session.num_sessions(), 2);
    }
}
