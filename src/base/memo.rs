//! A bounded memo of a pure computation's results, shared by threads.

use std::collections::HashMap;
use std::hash::Hash;
use std::sync::Mutex;

/// What a pure computation returned for a key, kept while fewer than `capacity` entries are held
/// (a long-lived process, such as a test binary, starts afresh when it is full).
///
/// The lock is not held while computing: two threads asking for the same new key both compute it,
/// and a pure computation gives both the same value.
pub struct Memo<K, V> {
    known: Mutex<HashMap<K, V>>,
    capacity: usize,
}

impl<K: Hash + Eq, V> Memo<K, V> {
    pub fn new(capacity: usize) -> Self {
        Self {
            known: Mutex::new(HashMap::new()),
            capacity,
        }
    }

    /// `read` of the value kept for `key`, or of `compute()`'s, which is then kept.
    pub fn read_or_compute<R>(&self, key: K, read: impl Fn(&V) -> R, compute: impl FnOnce() -> V) -> R {
        if let Some(r) = self.known.lock().ok().and_then(|m| m.get(&key).map(&read)) {
            return r;
        }
        let value = compute();
        let r = read(&value);
        if let Ok(mut m) = self.known.lock() {
            if m.len() >= self.capacity {
                m.clear();
            }
            m.insert(key, value);
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kept_value_is_read_back_without_computing_and_a_full_memo_starts_afresh() {
        let memo = Memo::new(2);
        let calls = std::cell::Cell::new(0);
        let square = |k: u32| {
            calls.set(calls.get() + 1);
            k * k
        };
        assert_eq!(memo.read_or_compute(3, |v| *v, || square(3)), 9);
        assert_eq!(memo.read_or_compute(3, |v| *v + 1, || square(3)), 10);
        assert_eq!(calls.get(), 1, "the second read is the kept value");
        memo.read_or_compute(4, |v| *v, || square(4));
        assert_eq!(calls.get(), 2);
        // Two entries held: the third clears them, so 3 is computed again.
        memo.read_or_compute(5, |v| *v, || square(5));
        memo.read_or_compute(3, |v| *v, || square(3));
        assert_eq!(calls.get(), 4);
    }
}
