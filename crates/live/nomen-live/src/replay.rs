//! `nomen replay`: a recording published to a broker with its timing: each input message on
//! its topic (`nomen/in/<kind>/<source>`), the header's registry first, retained.

use crate::broker::BrokerAddr;
use crate::outbox::{ConnectionCounts, Outbox};
use crate::topics::{REGISTRY_TOPIC, input_topic};
use crate::{LiveError, Result};
use nomen_core::SessionTime;
use rumqttc::{Client, Event, Outgoing, Packet, QoS};
use std::path::Path;
use std::str::FromStr;
use std::sync::Arc;
use std::sync::mpsc::sync_channel;
use std::time::{Duration, Instant};

/// How fast a recording is replayed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Speed {
    /// This many seconds of the recording per second of wall time (1: real time).
    Times(f64),
    /// As fast as the broker takes them.
    Max,
}

impl FromStr for Speed {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s == "max" {
            return Ok(Speed::Max);
        }
        match s.parse::<f64>() {
            Ok(x) if x.is_finite() && x > 0.0 => Ok(Speed::Times(x)),
            _ => Err(format!(
                "'{s}' is not a speed: a positive number (1 is real time) or max"
            )),
        }
    }
}

/// When each message is due: its time since the first message, divided by the speed, after the
/// wall time the first was sent. Sans-IO: the wall clock comes in as an argument.
#[derive(Debug, Clone)]
pub struct Pacer {
    speed: Speed,
    start: Option<(SessionTime, Instant)>,
}

impl Pacer {
    /// A pacer at `speed`.
    pub fn new(speed: Speed) -> Self {
        Pacer { speed, start: None }
    }

    /// How long to wait at wall time `now` before sending a message stamped `t` (zero when it is
    /// due or late; a message stamped before the first is due at once).
    pub fn wait(&mut self, t: SessionTime, now: Instant) -> Duration {
        let Speed::Times(speed) = self.speed else {
            return Duration::ZERO;
        };
        let (t0, wall0) = *self.start.get_or_insert((t, now));
        let after_s = (t.as_ns().saturating_sub(t0.as_ns())) as f64 * 1e-9 / speed;
        if !(after_s.is_finite() && after_s > 0.0) {
            return Duration::ZERO;
        }
        let due = wall0 + Duration::from_secs_f64(after_s.min(1e9));
        due.saturating_duration_since(now)
    }
}

/// How `replay` runs.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// The broker.
    pub broker: BrokerAddr,
    /// The MQTT client id.
    pub client_id: String,
    /// The pace.
    pub speed: Speed,
    /// How long to wait for the connection.
    pub connect_timeout: Duration,
}

/// What a replay did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplaySummary {
    /// Input messages published (QoS 1, each acknowledged by the broker).
    pub num_published: u64,
    /// Messages not published: engine outputs and ground truth in the recording.
    pub num_not_inputs: u64,
    /// Whether the header's registry was published (retained).
    pub has_registry: bool,
    /// Wall time from the first publish to the broker's last acknowledgement, s.
    pub elapsed_s: f64,
    /// Messages published again after a reconnection (the broker had not acknowledged them).
    pub num_published_again: u64,
}

/// The most publishes a replay holds unacknowledged before it waits for the broker (while the
/// broker is away, the replay pauses here instead of reading on).
const MAX_PENDING: usize = 4096;

/// How long the end of a replay waits for the broker's acknowledgements.
const ACK_TIMEOUT: Duration = Duration::from_secs(60);

/// Publishes `recording` to the broker: its registry (retained, QoS 1) when the header carries
/// one, then every input message at its time (QoS 1), and waits until the broker has
/// acknowledged them all. A bad line stops the replay with its error, after what came before it.
/// Publishes go through an [`Outbox`]: after the broker restarts, what it had not acknowledged is
/// published again (at least once).
pub fn replay(recording: &Path, options: &ReplayOptions) -> Result<ReplaySummary> {
    let mut reader =
        nomen_mcap::open_recording(recording, nomen_recording::ReadOptions::default())?;
    let mqtt = options.broker.client_options(&options.client_id)?;
    let (client, mut connection) = Client::new(mqtt, 1024);
    let counts = Arc::new(ConnectionCounts::default());
    let (connected_tx, connected) = sync_channel(1);
    let network = {
        let counts = Arc::clone(&counts);
        std::thread::Builder::new()
            .name("nomen-replay".to_owned())
            .spawn(move || {
                let mut is_first = true;
                for event in connection.iter() {
                    match event {
                        Ok(Event::Incoming(Packet::ConnAck(_))) => {
                            counts.connected();
                            if is_first {
                                is_first = false;
                                let _ = connected_tx.try_send(Ok(()));
                            }
                        }
                        Ok(Event::Incoming(Packet::PubAck(_))) => counts.acked(),
                        Ok(Event::Outgoing(Outgoing::Publish(_))) => counts.written(),
                        Ok(Event::Outgoing(Outgoing::Disconnect)) => return,
                        Ok(_) => {}
                        Err(e) => {
                            if is_first {
                                let _ = connected_tx.try_send(Err(e.to_string()));
                                return;
                            }
                            counts.disconnected();
                            std::thread::sleep(Duration::from_millis(500));
                        }
                    }
                }
            })
            .map_err(|e| LiveError::Io {
                what: "cannot start the mqtt thread".to_owned(),
                source: e,
            })?
    };
    let connect_error = |why: String| LiveError::Mqtt {
        what: format!("connect to {}", options.broker),
        why,
    };
    match connected.recv_timeout(options.connect_timeout) {
        Ok(Ok(())) => {}
        Ok(Err(why)) => return Err(connect_error(options.broker.connect_failure(&why))),
        Err(_) => {
            return Err(connect_error(format!(
                "no answer in {} s",
                options.connect_timeout.as_secs_f64()
            )));
        }
    }
    // Never full: the replay waits for acknowledgements at MAX_PENDING.
    let mut outbox = Outbox::new(MAX_PENDING + 2);
    // The registry is retained; every publish is kept until acknowledged.
    let publish = |outbox: &mut Outbox, topic: Option<String>, payload: Vec<u8>| {
        if let Some(topic) = topic {
            let _ = outbox.push(topic, payload, true);
        }
        outbox.sync(&counts.state(), |topic: &str, payload: &[u8]| {
            client
                .publish(
                    topic,
                    QoS::AtLeastOnce,
                    topic == REGISTRY_TOPIC,
                    payload.to_vec(),
                )
                .map_err(|e| LiveError::Mqtt {
                    what: "publish".to_owned(),
                    why: e.to_string(),
                })
        })
    };
    let started = Instant::now();
    let mut summary = ReplaySummary {
        num_published: 0,
        num_not_inputs: 0,
        has_registry: false,
        elapsed_s: 0.0,
        num_published_again: 0,
    };
    if let Some(registry) = &reader.header().registry {
        publish(
            &mut outbox,
            Some(REGISTRY_TOPIC.to_owned()),
            to_json(registry),
        )?;
        summary.has_registry = true;
    }
    let mut pacer = Pacer::new(options.speed);
    let mut read_error = None;
    for m in reader.by_ref() {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                read_error = Some(e);
                break;
            }
        };
        let Some(topic) = input_topic(&m) else {
            summary.num_not_inputs += 1;
            continue;
        };
        let wait = pacer.wait(m.t(), Instant::now());
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        publish(&mut outbox, Some(topic), to_json(&m))?;
        summary.num_published += 1;
        let waiting = Instant::now();
        while outbox.len() > MAX_PENDING {
            if waiting.elapsed() > ACK_TIMEOUT {
                return Err(LiveError::Mqtt {
                    what: "replay".to_owned(),
                    why: format!(
                        "the broker acknowledged nothing for {} s",
                        ACK_TIMEOUT.as_secs()
                    ),
                });
            }
            std::thread::sleep(Duration::from_millis(5));
            publish(&mut outbox, None, Vec::new())?;
        }
    }
    // Until the broker has acknowledged everything (settled twice 20 ms apart: a publish handed
    // before a reconnection may come after the counts matched).
    let waiting = Instant::now();
    let mut settled_since = None;
    while waiting.elapsed() < ACK_TIMEOUT {
        publish(&mut outbox, None, Vec::new())?;
        if outbox.is_settled(&counts.state()) {
            let since = *settled_since.get_or_insert_with(Instant::now);
            if since.elapsed() >= Duration::from_millis(20) {
                break;
            }
        } else {
            settled_since = None;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    summary.elapsed_s = started.elapsed().as_secs_f64();
    summary.num_published_again = outbox.num_handed_again();
    let is_settled = outbox.is_settled(&counts.state());
    let _ = client.disconnect();
    let _ = network.join();
    if let Some(e) = read_error {
        return Err(e.into());
    }
    if !is_settled {
        return Err(LiveError::Mqtt {
            what: "replay".to_owned(),
            why: format!(
                "the broker had not acknowledged {} messages after {} s",
                outbox.len(),
                ACK_TIMEOUT.as_secs()
            ),
        });
    }
    Ok(summary)
}

fn to_json<T: serde::Serialize>(value: &T) -> Vec<u8> {
    // Values read from a recording serialise again (they were checked finite).
    serde_json::to_vec(value).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speeds_are_numbers_or_max() {
        assert_eq!("max".parse::<Speed>(), Ok(Speed::Max));
        assert_eq!("2.5".parse::<Speed>(), Ok(Speed::Times(2.5)));
        assert!("0".parse::<Speed>().is_err());
        assert!("fast".parse::<Speed>().is_err());
    }

    #[test]
    fn at_twice_real_time_a_message_one_second_in_is_due_half_a_second_after_the_first() {
        let mut pacer = Pacer::new(Speed::Times(2.0));
        let wall0 = Instant::now();
        assert_eq!(
            pacer.wait(SessionTime::from_ns(5_000_000_000), wall0),
            Duration::ZERO
        );
        let wait = pacer.wait(SessionTime::from_ns(6_000_000_000), wall0);
        assert_eq!(wait, Duration::from_millis(500));
        let later = wall0 + Duration::from_millis(700);
        assert_eq!(
            pacer.wait(SessionTime::from_ns(6_000_000_000), later),
            Duration::ZERO
        );
        // Before the first: due at once.
        assert_eq!(pacer.wait(SessionTime::from_ns(0), wall0), Duration::ZERO);
    }

    #[test]
    fn at_max_speed_nothing_waits() {
        let mut pacer = Pacer::new(Speed::Max);
        let now = Instant::now();
        pacer.wait(SessionTime::from_ns(0), now);
        assert_eq!(
            pacer.wait(SessionTime::from_ns(10_000_000_000), now),
            Duration::ZERO
        );
    }
}
