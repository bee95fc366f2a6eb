//! The outputs on their way to the broker: kept until the broker has acknowledged them, and
//! handed to the MQTT client again after a reconnection. Sans-IO: the connection's counts come
//! in as values, the hand-over is a closure.
//!
//! rumqttc keeps a publish it has not had acknowledged across a reconnection only when the
//! broker resumes the session; a broker that restarted without persistence has none, and the
//! client then discards its in-flight publishes and every request it held when the connection
//! failed. So the service keeps its own: MQTT has a broker acknowledge QoS 1 publishes in the
//! order it received them (3.1.1, §4.6), so on a connection the k-th acknowledgement is of the
//! k-th publish written. After a reconnection the client writes first what was handed to it
//! after the old connection failed (at most what was handed and not acknowledged before), then
//! what is handed again: the count of those unacknowledged publishes is taken off the new
//! connection's acknowledgements before they are matched to hand-overs, so that nothing is
//! taken for acknowledged that was not (at the price of handing a few twice: at least once).
//!
//! The outbox is bounded: a publish that finds it full is dropped and counted
//! ([`Outbox::num_dropped`]). The oldest are kept, so that what a subscriber receives after an
//! outage goes on without a gap from where it left off, up to the bound.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The MQTT client's connection, as its thread counts it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ConnectionState {
    /// Connections so far (incremented at each ConnAck).
    pub connection: u64,
    /// Connected now (from a ConnAck until the next connection error).
    pub is_connected: bool,
    /// Publishes written on the current connection.
    pub num_written: u64,
    /// Acknowledgements received on the current connection.
    pub num_acked: u64,
}

/// The counts behind [`ConnectionState`], kept by the thread that polls the MQTT connection
/// and read by the one that publishes.
#[derive(Debug, Default)]
pub struct ConnectionCounts {
    connection: AtomicU64,
    is_connected: AtomicBool,
    num_written: AtomicU64,
    num_acked: AtomicU64,
}

impl ConnectionCounts {
    /// A ConnAck: a new connection; its counts start at zero (reset before the connection is
    /// counted, so that a reader never sees an older connection's counts as the new one's).
    pub fn connected(&self) {
        self.num_written.store(0, Ordering::SeqCst);
        self.num_acked.store(0, Ordering::SeqCst);
        self.connection.fetch_add(1, Ordering::SeqCst);
        self.is_connected.store(true, Ordering::SeqCst);
    }

    /// A connection error: down until the next ConnAck.
    pub fn disconnected(&self) {
        self.is_connected.store(false, Ordering::SeqCst);
    }

    /// A publish written (rumqttc's `Outgoing::Publish`).
    pub fn written(&self) {
        self.num_written.fetch_add(1, Ordering::SeqCst);
    }

    /// A PubAck.
    pub fn acked(&self) {
        self.num_acked.fetch_add(1, Ordering::SeqCst);
    }

    /// Whether connected now.
    pub fn is_connected(&self) -> bool {
        self.is_connected.load(Ordering::SeqCst)
    }

    /// The counts, all of one connection: no acknowledgement of a connection comes before its
    /// ConnAck is handled, so counts read between two equal reads of `connection` are at most
    /// too low (zero after a reset).
    pub fn state(&self) -> ConnectionState {
        loop {
            let connection = self.connection.load(Ordering::SeqCst);
            let state = ConnectionState {
                connection,
                is_connected: self.is_connected.load(Ordering::SeqCst),
                num_written: self.num_written.load(Ordering::SeqCst),
                num_acked: self.num_acked.load(Ordering::SeqCst),
            };
            if self.connection.load(Ordering::SeqCst) == connection {
                return state;
            }
        }
    }
}

struct Entry {
    topic: String,
    payload: Vec<u8>,
    is_kept_on_loss: bool,
}

/// The publishes not known to be acknowledged, oldest first, at most `capacity`.
pub struct Outbox {
    capacity: usize,
    /// Publishes refused because the outbox was full.
    num_dropped: u64,
    /// Handed ones first (on `connection`), then those waiting for a connection.
    entries: VecDeque<Entry>,
    /// How many of `entries` were handed.
    num_handed_now: usize,
    connection: u64,
    /// Acknowledgements of the current connection that may be of publishes handed before it.
    slack: u64,
    /// Hand-overs on the current connection, and how many of them were found acknowledged.
    num_handed: u64,
    num_pruned: u64,
    num_handed_again: u64,
}

impl Outbox {
    /// An empty outbox that holds at most `capacity` publishes (at least one).
    pub fn new(capacity: usize) -> Self {
        Outbox {
            capacity: capacity.max(1),
            num_dropped: 0,
            entries: VecDeque::new(),
            num_handed_now: 0,
            connection: 0,
            slack: 0,
            num_handed: 0,
            num_pruned: 0,
            num_handed_again: 0,
        }
    }

    /// A publish to make. `is_kept_on_loss`: hand it again after a reconnection if it was not
    /// acknowledged (decisions and events; a health report is replaced by the next one).
    /// `false` when the outbox is full: the publish is dropped and counted.
    pub fn push(&mut self, topic: String, payload: Vec<u8>, is_kept_on_loss: bool) -> bool {
        if self.is_full() {
            self.num_dropped += 1;
            return false;
        }
        self.entries.push_back(Entry {
            topic,
            payload,
            is_kept_on_loss,
        });
        true
    }

    /// Whether a publish pushed now would be dropped.
    pub fn is_full(&self) -> bool {
        self.entries.len() >= self.capacity
    }

    /// The most publishes it holds.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Publishes dropped so far because the outbox was full.
    pub fn num_dropped(&self) -> u64 {
        self.num_dropped
    }

    /// Publishes not known to be acknowledged.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Publishes handed again after reconnections so far.
    pub fn num_handed_again(&self) -> u64 {
        self.num_handed_again
    }

    /// Whether everything handed on the current connection was written and acknowledged and
    /// nothing waits (the end of a service: its last publishes are at the broker).
    pub fn is_settled(&self, state: &ConnectionState) -> bool {
        state.connection == self.connection
            && state.is_connected
            && self.num_handed_now == self.entries.len()
            && state.num_written >= self.num_handed
            && state.num_acked >= state.num_written
    }

    /// Brings the outbox up to date with the connection: forgets what the broker acknowledged;
    /// on a new connection hands again, oldest first, every decision and event not known
    /// acknowledged; then, when connected, hands (through `hand`) what waits.
    pub fn sync<E>(
        &mut self,
        state: &ConnectionState,
        mut hand: impl FnMut(&str, &[u8]) -> Result<(), E>,
    ) -> Result<(), E> {
        if state.connection != self.connection {
            // What was handed and not acknowledged may be lost, or may come first on the new
            // connection: its count is the slack.
            let handed = self.num_handed_now;
            self.slack = handed as u64;
            self.num_handed_again += self
                .entries
                .iter()
                .take(handed)
                .filter(|e| e.is_kept_on_loss)
                .count() as u64;
            // Health reports handed and not acknowledged are stale: left out.
            let mut k = 0;
            self.entries.retain(|e| {
                k += 1;
                e.is_kept_on_loss || k > handed
            });
            self.num_handed_now = 0;
            self.connection = state.connection;
            self.num_handed = 0;
            self.num_pruned = 0;
        } else {
            let num_known = state.num_acked.saturating_sub(self.slack);
            while self.num_pruned < num_known && self.num_handed_now > 0 {
                self.entries.pop_front();
                self.num_handed_now -= 1;
                self.num_pruned += 1;
            }
        }
        if state.is_connected {
            while let Some(e) = self.entries.get(self.num_handed_now) {
                hand(&e.topic, &e.payload)?;
                self.num_handed_now += 1;
                self.num_handed += 1;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(connection: u64, num_written: u64, num_acked: u64) -> ConnectionState {
        ConnectionState {
            connection,
            is_connected: true,
            num_written,
            num_acked,
        }
    }

    /// Syncs, recording what was handed.
    fn sync(outbox: &mut Outbox, s: ConnectionState) -> Vec<String> {
        let mut handed = Vec::new();
        outbox
            .sync::<()>(&s, |topic: &str, _: &[u8]| {
                handed.push(topic.to_owned());
                Ok(())
            })
            .unwrap();
        handed
    }

    #[test]
    fn acknowledged_publishes_are_forgotten_in_order() {
        let mut outbox = Outbox::new(100);
        for k in 0..5 {
            assert!(outbox.push(format!("d{k}"), Vec::new(), true));
        }
        assert_eq!(sync(&mut outbox, state(1, 0, 0)).len(), 5);
        assert!(sync(&mut outbox, state(1, 5, 3)).is_empty());
        assert_eq!(outbox.len(), 2);
        assert!(!outbox.is_settled(&state(1, 5, 3)));
        sync(&mut outbox, state(1, 5, 5));
        assert!(outbox.is_empty() && outbox.is_settled(&state(1, 5, 5)));
    }

    #[test]
    fn nothing_waits_for_a_connection_that_is_down() {
        let mut outbox = Outbox::new(100);
        outbox.push("d0".to_owned(), Vec::new(), true);
        let down = ConnectionState {
            connection: 1,
            is_connected: false,
            ..ConnectionState::default()
        };
        assert!(sync(&mut outbox, down).is_empty());
        assert_eq!(sync(&mut outbox, state(1, 0, 0)), ["d0"]);
    }

    #[test]
    fn a_reconnection_hands_again_what_was_not_acknowledged_but_not_health() {
        let mut outbox = Outbox::new(100);
        for k in 0..4 {
            assert!(outbox.push(format!("d{k}"), Vec::new(), true));
        }
        outbox.push("health".to_owned(), Vec::new(), false);
        sync(&mut outbox, state(1, 0, 0));
        // Two acknowledged; the connection fails; a decision comes while it is down.
        sync(&mut outbox, state(1, 5, 2));
        outbox.push("d4".to_owned(), Vec::new(), true);
        let down = ConnectionState {
            connection: 1,
            is_connected: false,
            num_written: 5,
            num_acked: 2,
        };
        assert!(sync(&mut outbox, down).is_empty());
        assert_eq!(sync(&mut outbox, state(2, 0, 0)), ["d2", "d3", "d4"]);
        assert_eq!(outbox.num_handed_again(), 2);
    }

    #[test]
    fn publishes_written_first_on_a_new_connection_are_not_taken_for_acknowledged() {
        let mut outbox = Outbox::new(100);
        for k in 0..3 {
            assert!(outbox.push(format!("d{k}"), Vec::new(), true));
        }
        sync(&mut outbox, state(1, 0, 0));
        // Connection 1 fails with none acknowledged; d2 had been handed after the client
        // emptied its queue, so it is written first on connection 2, then d0, d1, d2 again.
        assert_eq!(sync(&mut outbox, state(2, 0, 0)), ["d0", "d1", "d2"]);
        // Three acknowledgements: d2 (the old hand-over), d0, d1. The slack of 3 keeps all.
        sync(&mut outbox, state(2, 4, 3));
        assert_eq!(outbox.len(), 3);
        // All four acknowledged: still the slack's worth kept, never one too few.
        sync(&mut outbox, state(2, 4, 4));
        assert_eq!(outbox.len(), 2);
        assert!(outbox.is_settled(&state(2, 4, 4)));
    }

    #[test]
    fn a_full_outbox_keeps_the_oldest_and_counts_what_it_drops_across_an_outage() {
        let mut outbox = Outbox::new(3);
        for k in 0..2 {
            assert!(outbox.push(format!("d{k}"), Vec::new(), true));
        }
        assert_eq!(sync(&mut outbox, state(1, 0, 0)), ["d0", "d1"]);
        // The broker goes away before acknowledging them; decisions go on coming.
        let down = ConnectionState {
            connection: 1,
            is_connected: false,
            num_written: 2,
            num_acked: 0,
        };
        for k in 2..6 {
            let _ = outbox.push(format!("d{k}"), Vec::new(), true);
            assert!(sync(&mut outbox, down).is_empty());
        }
        assert!(outbox.is_full());
        assert_eq!((outbox.len(), outbox.num_dropped()), (3, 3));
        // Back: the oldest three are handed again, in order; the rest were counted, not kept.
        assert_eq!(sync(&mut outbox, state(2, 0, 0)), ["d0", "d1", "d2"]);
        // Acknowledged (past the slack of the two handed before the outage): room again.
        sync(&mut outbox, state(2, 3, 3));
        assert_eq!(outbox.len(), 2);
        assert!(outbox.push("d6".to_owned(), Vec::new(), true));
        assert_eq!(outbox.num_dropped(), 3);
    }
}
