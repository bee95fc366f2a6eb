//! `nomen replay`: a recording published to a broker with its timing: each input message on
//! its topic (`nomen/in/<kind>/<source>`), the header's registry first, retained.

use crate::broker::BrokerAddr;
use crate::topics::{REGISTRY_TOPIC, input_topic};
use crate::{LiveError, Result};
use nomen_core::SessionTime;
use nomen_recording::RecordingReader;
use rumqttc::{Client, Event, Outgoing, Packet, QoS};
use std::path::Path;
use std::str::FromStr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
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
}

/// How long the end of a replay waits for the broker's acknowledgements.
const ACK_TIMEOUT: Duration = Duration::from_secs(60);

/// Publishes `recording` to the broker: its registry (retained, QoS 1) when the header carries
/// one, then every input message at its time (QoS 1), and waits until the broker has
/// acknowledged them all. A bad line stops the replay with its error, after what came before it.
pub fn replay(recording: &Path, options: &ReplayOptions) -> Result<ReplaySummary> {
    let mut reader = RecordingReader::open(recording)?;
    let mqtt = options.broker.client_options(&options.client_id);
    let (client, mut connection) = Client::new(mqtt, 1024);
    let num_acked = Arc::new(AtomicU64::new(0));
    let (connected_tx, connected) = sync_channel(1);
    let network = {
        let num_acked = Arc::clone(&num_acked);
        std::thread::Builder::new()
            .name("nomen-replay".to_owned())
            .spawn(move || {
                let mut is_first = true;
                for event in connection.iter() {
                    match event {
                        Ok(Event::Incoming(Packet::ConnAck(_))) if is_first => {
                            is_first = false;
                            let _ = connected_tx.try_send(Ok(()));
                        }
                        Ok(Event::Incoming(Packet::PubAck(_))) => {
                            num_acked.fetch_add(1, Ordering::Relaxed);
                        }
                        Ok(Event::Outgoing(Outgoing::Disconnect)) => return,
                        Ok(_) => {}
                        Err(e) => {
                            if is_first {
                                let _ = connected_tx.try_send(Err(e.to_string()));
                                return;
                            }
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
        Ok(Err(why)) => return Err(connect_error(why)),
        Err(_) => {
            return Err(connect_error(format!(
                "no answer in {} s",
                options.connect_timeout.as_secs_f64()
            )));
        }
    }
    let publish = |topic: String, retain: bool, payload: Vec<u8>| {
        client
            .publish(topic, QoS::AtLeastOnce, retain, payload)
            .map_err(|e| LiveError::Mqtt {
                what: "publish".to_owned(),
                why: e.to_string(),
            })
    };
    let started = Instant::now();
    let mut summary = ReplaySummary {
        num_published: 0,
        num_not_inputs: 0,
        has_registry: false,
        elapsed_s: 0.0,
    };
    let mut num_sent = 0u64;
    if let Some(registry) = &reader.header().registry {
        publish(REGISTRY_TOPIC.to_owned(), true, to_json(registry))?;
        summary.has_registry = true;
        num_sent += 1;
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
        publish(topic, false, to_json(&m))?;
        summary.num_published += 1;
        num_sent += 1;
    }
    let waiting = Instant::now();
    while num_acked.load(Ordering::Relaxed) < num_sent && waiting.elapsed() < ACK_TIMEOUT {
        std::thread::sleep(Duration::from_millis(2));
    }
    summary.elapsed_s = started.elapsed().as_secs_f64();
    let num_acked = num_acked.load(Ordering::Relaxed);
    let _ = client.disconnect();
    let _ = network.join();
    if let Some(e) = read_error {
        return Err(e.into());
    }
    if num_acked < num_sent {
        return Err(LiveError::Mqtt {
            what: "replay".to_owned(),
            why: format!(
                "the broker acknowledged {num_acked} of {num_sent} messages in {} s",
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
