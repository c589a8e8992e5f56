//! How the pipelines show long work: a reporter the program installs once (the binary's draws
//! indicatif bars on stderr), as `log` does for messages. Without one, nothing is shown, so a
//! library user's program stays quiet unless it asks.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

/// What shows progress: bars for counted work and notes for steps.
pub trait Reporter: Send + Sync {
    /// A bar of `len` steps labelled `what`.
    fn bar(&self, len: u64, what: &str) -> Box<dyn BarView>;
    /// A line about a step of the work ("2/4 training the network").
    fn note(&self, text: &str);
}

/// One bar as a reporter draws it.
pub trait BarView: Send + Sync {
    /// Steps done so far.
    fn set_position(&self, pos: u64);
    /// Adds `delta` steps done.
    fn inc(&self, delta: u64);
    /// Steps done so far.
    fn position(&self) -> u64;
    /// The number of steps, when it becomes known.
    fn set_length(&self, len: u64);
    /// The label.
    fn set_message(&self, msg: String);
    /// Removes the bar.
    fn finish_and_clear(&self);
}

static REPORTER: OnceLock<Box<dyn Reporter>> = OnceLock::new();

/// Installs the reporter every pipeline of this process reports to; only the first call has an
/// effect (returns false for the others).
pub fn set_reporter(reporter: Box<dyn Reporter>) -> bool {
    REPORTER.set(reporter).is_ok()
}

/// A line about a step of the work, shown by the installed reporter.
pub fn note(text: &str) {
    if let Some(r) = REPORTER.get() {
        r.note(text);
    }
}

/// A progress bar of `len` steps labelled `what` (drawn by the installed reporter, if any).
pub fn bar(len: u64, what: &str) -> Bar {
    Bar {
        view: REPORTER.get().map(|r| r.bar(len, what)),
        hidden: AtomicBool::new(false),
        position: std::sync::atomic::AtomicU64::new(0),
    }
}

/// A progress bar; safe to advance from many threads.
pub struct Bar {
    view: Option<Box<dyn BarView>>,
    hidden: AtomicBool,
    /// Kept here too, so that `position` answers without a reporter.
    position: std::sync::atomic::AtomicU64,
}

impl Bar {
    fn shown(&self) -> Option<&dyn BarView> {
        if self.hidden.load(Ordering::Relaxed) {
            None
        } else {
            self.view.as_deref()
        }
    }

    /// Stops drawing this bar (its work goes on; used when results go out as JSON).
    pub fn hide(&self) {
        if let Some(v) = self.shown() {
            v.finish_and_clear();
        }
        self.hidden.store(true, Ordering::Relaxed);
    }

    /// Steps done so far.
    pub fn set_position(&self, pos: u64) {
        self.position.store(pos, Ordering::Relaxed);
        if let Some(v) = self.shown() {
            v.set_position(pos);
        }
    }

    /// Adds `delta` steps done.
    pub fn inc(&self, delta: u64) {
        self.position.fetch_add(delta, Ordering::Relaxed);
        if let Some(v) = self.shown() {
            v.inc(delta);
        }
    }

    /// Steps done so far.
    pub fn position(&self) -> u64 {
        self.position.load(Ordering::Relaxed)
    }

    /// The number of steps, when it becomes known.
    pub fn set_length(&self, len: u64) {
        if let Some(v) = self.shown() {
            v.set_length(len);
        }
    }

    /// The label.
    pub fn set_message(&self, msg: String) {
        if let Some(v) = self.shown() {
            v.set_message(msg);
        }
    }

    /// Removes the bar.
    pub fn finish_and_clear(&self) {
        if let Some(v) = self.shown() {
            v.finish_and_clear();
        }
    }
}

/// What a training run shows: a bar per epoch, and (when `lines`) a note for what was loaded
/// and one per finished epoch. `prefix` names the run in the bar and the notes ("" for the
/// pose network, "lstm " for a sequence model, ...).
pub struct TrainingDisplay<'a, L, E> {
    /// Notes for what was loaded and each epoch.
    pub lines: bool,
    /// Label of the bar and of resume / early-stop notes.
    pub prefix: &'a str,
    /// The note for what was loaded.
    pub loaded: &'a dyn Fn(&L) -> String,
    /// The note for a finished epoch.
    pub epoch: &'a dyn Fn(&E) -> String,
}

impl<L, E> TrainingDisplay<'_, L, E> {
    /// Runs `train` with this display fed from its events.
    pub fn run<R>(
        &self,
        train: impl FnOnce(&mut dyn FnMut(&learn::Progress<L, E>)) -> learn::Result<R>,
    ) -> learn::Result<R> {
        use learn::Progress;
        let mut pb: Option<Bar> = None;
        let prefix = self.prefix;
        let result = train(&mut |event| match event {
            Progress::Loaded(l) => {
                if self.lines {
                    note(&(self.loaded)(l));
                }
            }
            Progress::Resumed { epoch } => note(&format!("{prefix}resuming after epoch {epoch}")),
            Progress::Step {
                epoch,
                step,
                steps,
                loss,
            } => {
                let p =
                    pb.get_or_insert_with(|| bar(*steps as u64, &format!("{prefix}epoch {epoch}")));
                p.set_position(*step as u64);
                p.set_message(format!("{prefix}epoch {epoch} loss {loss:.3}"));
            }
            Progress::Epoch(m) => {
                if let Some(p) = pb.take() {
                    p.finish_and_clear();
                }
                if self.lines {
                    note(&(self.epoch)(m));
                }
            }
            Progress::EarlyStop { epoch, best_epoch } => {
                if self.lines {
                    note(&format!(
                        "{prefix}early stop after epoch {epoch}; keeping epoch {best_epoch}"
                    ));
                }
            }
        });
        if let Some(p) = pb {
            p.finish_and_clear();
        }
        result
    }
}
