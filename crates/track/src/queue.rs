//! The bounded hand-over between the frame reader and the estimators.
//!
//! A live source (a camera) does not wait: when the estimators fall behind, the oldest waiting
//! frame is dropped and counted, so the pose stream stays current instead of growing a backlog.
//! A file source waits instead, so that every frame is processed.

use std::collections::VecDeque;
use std::sync::{Condvar, Mutex};

/// What a full queue does with a new item.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Overflow {
    /// Drop the oldest waiting item (live sources).
    DropOldest,
    /// Make the producer wait (files).
    Block,
}

struct Inner<T> {
    items: VecDeque<T>,
    closed: bool,
}

/// A bounded multi-producer queue with a drop-oldest or blocking policy.
pub struct FrameQueue<T> {
    inner: Mutex<Inner<T>>,
    changed: Condvar,
    capacity: usize,
    overflow: Overflow,
}

impl<T> FrameQueue<T> {
    /// An empty queue holding at most `capacity` items (at least 1).
    pub fn new(capacity: usize, overflow: Overflow) -> FrameQueue<T> {
        FrameQueue {
            inner: Mutex::new(Inner {
                items: VecDeque::new(),
                closed: false,
            }),
            changed: Condvar::new(),
            capacity: capacity.max(1),
            overflow,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner<T>> {
        // A panic elsewhere must not wedge the pipeline: the data is a plain queue.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Adds `item`; returns how many items were dropped to make room (0 or 1), or `None` when
    /// the queue is closed (the consumer has gone).
    pub fn push(&self, item: T) -> Option<usize> {
        let mut g = self.lock();
        let mut dropped = 0;
        loop {
            if g.closed {
                return None;
            }
            if g.items.len() < self.capacity {
                break;
            }
            match self.overflow {
                Overflow::DropOldest => {
                    g.items.pop_front();
                    dropped += 1;
                }
                Overflow::Block => {
                    g = self.changed.wait(g).unwrap_or_else(|p| p.into_inner());
                }
            }
        }
        g.items.push_back(item);
        self.changed.notify_all();
        Some(dropped)
    }

    /// The oldest item, waiting for one; `None` once the queue is closed and empty.
    pub fn pop(&self) -> Option<T> {
        let mut g = self.lock();
        loop {
            if let Some(item) = g.items.pop_front() {
                self.changed.notify_all();
                return Some(item);
            }
            if g.closed {
                return None;
            }
            g = self.changed.wait(g).unwrap_or_else(|p| p.into_inner());
        }
    }

    /// Closes the queue: producers stop, the consumer drains what is left.
    pub fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn a_full_live_queue_drops_the_oldest() {
        let q = FrameQueue::new(2, Overflow::DropOldest);
        assert_eq!(q.push(1), Some(0));
        assert_eq!(q.push(2), Some(0));
        assert_eq!(q.push(3), Some(1));
        assert_eq!(q.pop(), Some(2));
        q.close();
        assert_eq!(q.pop(), Some(3));
        assert_eq!(q.pop(), None);
        assert_eq!(q.push(4), None);
    }

    #[test]
    fn a_blocking_queue_loses_nothing() {
        let q = Arc::new(FrameQueue::new(1, Overflow::Block));
        let producer = {
            let q = Arc::clone(&q);
            std::thread::spawn(move || {
                for i in 0..100 {
                    assert_eq!(q.push(i), Some(0));
                }
                q.close();
            })
        };
        let got: Vec<i32> = std::iter::from_fn(|| q.pop()).collect();
        producer.join().expect("producer");
        assert_eq!(got, (0..100).collect::<Vec<_>>());
    }
}
