//! The engine's output does not depend on how messages interleave within the reorder window:
//! any arrival order that delays no message behind a later one of its source by more than
//! `reorder_window_s` gives the output of the time-ordered recording, byte for byte.
// Test helpers outside #[test] functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{Person, recording, registry};
use nomen_core::Message;
use nomen_engine::{EngineConfig, run_batch};
use proptest::prelude::*;
use std::sync::OnceLock;

/// Ana and Ben with wrist IMUs and an intruder, 10 s, and the engine's output on them in time
/// order (computed once).
fn reference() -> &'static (Vec<Person>, Vec<Message>, Vec<Message>) {
    static REFERENCE: OnceLock<(Vec<Person>, Vec<Message>, Vec<Message>)> = OnceLock::new();
    REFERENCE.get_or_init(|| {
        let people = vec![
            Person::new(Some("ana"), 0.9, 0.0, 1),
            Person::new(Some("ben"), 1.3, 1.5, 2),
            Person::new(None, 1.1, 3.0, 3),
        ];
        let msgs = recording(&people, 10.0);
        let (out, stats) = run_batch(&registry(&people), &msgs, &EngineConfig::default()).unwrap();
        assert_eq!(stats.rejected.total(), 0);
        (people, msgs, out)
    })
}

proptest! {
    // Each case runs the engine over 10 s of three people: a few cases cover many orders.
    #![proptest_config(ProptestConfig::with_cases(12))]

    #[test]
    fn any_arrival_order_within_the_reorder_window_gives_the_same_output(
        delays_ms in prop::collection::vec(0u32..240, 64),
        fraction_delayed in 0.05..1.0f64,
    ) {
        let (people, msgs, want) = reference();
        let config = EngineConfig::default();
        // Each message arrives at t + delay, delay below the reorder window (0.25 s); messages
        // are delivered in arrival order (ties in time order), so no message comes later than
        // 0.24 s behind a newer one of its source.
        let max_delay_ns = (config.reorder_window_s * 1e9) as i64 - 10_000_000;
        let mut arrivals: Vec<(i64, usize)> = msgs
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let pick = delays_ms[(i * 31 + i / 7) % delays_ms.len()];
                let is_delayed = f64::from(pick % 1000) / 240.0 < fraction_delayed;
                let delay_ns = if is_delayed { i64::from(pick) * 1_000_000 } else { 0 };
                (m.t().as_ns() + delay_ns.min(max_delay_ns), i)
            })
            .collect();
        arrivals.sort();
        let shuffled: Vec<Message> = arrivals.iter().map(|&(_, i)| msgs[i].clone()).collect();
        let (out, stats) = run_batch(&registry(people), &shuffled, &config).unwrap();
        prop_assert_eq!(stats.rejected.total(), 0);
        prop_assert!(&out == want, "output differs from the time-ordered run's");
    }
}
