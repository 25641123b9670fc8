//! Progress while fits run: the count of passes over the data and the ticker that reports it.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// How often [`ticking`] reports a count while work goes on.
pub const TICK: std::time::Duration = std::time::Duration::from_millis(250);

/// A count of passes over the data, shared by the fits that add to it and the display that
/// reads it ([`FitOptions::watch`](crate::fit::FitOptions::watch), [`ticking`]).
pub type Watch = std::sync::Arc<AtomicUsize>;

/// `what` and the passes over the data so far, as a progress message: `what · K evaluations in
/// all`, or the count alone where nothing is named.
pub fn with_count(what: &str, k: usize) -> String {
    if what.is_empty() {
        format!("{k} evaluations in all")
    } else {
        format!("{what} · {k} evaluations in all")
    }
}

/// Run `work`, calling `tick(count)` from another thread every [`TICK`] with `count`'s value while
/// it runs, once it is above 0 (a fit's passes over the data:
/// [`FitOptions::watch`](crate::fit::FitOptions::watch)). The ticker stops as `work` ends, also by
/// a panic.
pub fn ticking<T>(
    count: &AtomicUsize,
    tick: &(dyn Fn(usize) + Sync),
    work: impl FnOnce() -> T,
) -> T {
    /// Stops the ticker when dropped.
    struct Stop<'a>(&'a AtomicBool, std::thread::Thread);
    impl Drop for Stop<'_> {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Release);
            self.1.unpark();
        }
    }
    let done = AtomicBool::new(false);
    std::thread::scope(|s| {
        let ticker = s.spawn(|| {
            loop {
                std::thread::park_timeout(TICK);
                if done.load(Ordering::Acquire) {
                    break;
                }
                let k = count.load(Ordering::Relaxed);
                if k > 0 {
                    tick(k);
                }
            }
        });
        let _stop = Stop(&done, ticker.thread().clone());
        work()
    })
}
