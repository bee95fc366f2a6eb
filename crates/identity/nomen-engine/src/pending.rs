//! Samples received and not yet settled, in time order.

use std::collections::VecDeque;

/// Values waiting to settle, keyed by time (ns), oldest first, at most one per time.
///
/// A source sends in time order nearly always, so an insert is an append; one that arrives
/// late (within the reorder window) is put in its place. The queue holds only what the reorder
/// window and a filter's start keep back (tens of samples), so a place found by bisection and
/// a shift of the newer ones cost less than a tree's node per sample.
#[derive(Debug, Clone)]
pub(crate) struct Pending<T> {
    items: VecDeque<(i64, T)>,
}

impl<T> Default for Pending<T> {
    fn default() -> Self {
        Self {
            items: VecDeque::new(),
        }
    }
}

impl<T> Pending<T> {
    /// Puts `value` at time `t`; returns `false`, leaving the queue as it was, if a value at `t`
    /// is already waiting.
    pub(crate) fn insert(&mut self, t: i64, value: T) -> bool {
        if self.items.back().is_none_or(|(last, _)| t > *last) {
            self.items.push_back((t, value));
            return true;
        }
        let k = self.items.partition_point(|(s, _)| *s < t);
        if self.items.get(k).is_some_and(|(s, _)| *s == t) {
            return false;
        }
        self.items.insert(k, (t, value));
        true
    }

    /// The oldest waiting value.
    pub(crate) fn first(&self) -> Option<&(i64, T)> {
        self.items.front()
    }

    /// Removes the oldest waiting value.
    pub(crate) fn pop_first(&mut self) -> Option<(i64, T)> {
        self.items.pop_front()
    }

    /// The waiting values, oldest first.
    pub(crate) fn iter(&self) -> impl DoubleEndedIterator<Item = &(i64, T)> {
        self.items.iter()
    }

    /// The newest waiting value before `t`.
    pub(crate) fn last_before(&self, t: i64) -> Option<&(i64, T)> {
        let k = self.items.partition_point(|(s, _)| *s < t);
        k.checked_sub(1).and_then(|k| self.items.get(k))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_come_out_in_time_order_whatever_order_they_went_in() {
        let mut p = Pending::default();
        for t in [10, 20, 40, 30, 5, 50] {
            assert!(p.insert(t, t * 2));
        }
        // A second value at a waiting time is refused and changes nothing.
        assert!(!p.insert(30, 0));
        assert!(!p.insert(50, 0));
        let times: Vec<i64> = p.iter().map(|(t, _)| *t).collect();
        assert_eq!(times, [5, 10, 20, 30, 40, 50]);
        assert!(p.iter().all(|(t, v)| *v == t * 2));
        assert_eq!(p.last_before(30), Some(&(20, 40)));
        assert_eq!(p.last_before(31), Some(&(30, 60)));
        assert_eq!(p.last_before(5), None);
        assert_eq!(p.first(), Some(&(5, 10)));
        assert_eq!(p.pop_first(), Some((5, 10)));
        assert_eq!(p.first(), Some(&(10, 20)));
        // Once the oldest has left, its time may come again.
        assert!(p.insert(5, 1));
        assert_eq!(p.first(), Some(&(5, 1)));
    }
}
