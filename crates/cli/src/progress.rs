//! Progress bars for long work (indicatif, on stderr; hidden when stderr is not a terminal).

use indicatif::{ProgressBar, ProgressStyle};

/// A bar of `len` steps labelled `what`, with rate and time left.
pub fn bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    let style = ProgressStyle::with_template(
        "{msg:>10} [{bar:40.cyan/blue}] {pos}/{len} ({per_sec}, {eta} left)",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar())
    .progress_chars("=> ");
    pb.set_style(style);
    pb.set_message(what.to_string());
    pb
}

/// What a training run shows: a bar per epoch, and on stderr (when `lines`, also when stderr is
/// not a terminal, for logs) a line for what was loaded and one per finished epoch. `prefix`
/// names the run in the bar and the lines ("" for the pose network, "lstm " for a sequence
/// model, ...).
pub struct TrainingDisplay<'a, L, E> {
    /// Print lines on stderr.
    pub lines: bool,
    /// Label of the bar and of resume / early-stop lines.
    pub prefix: &'a str,
    /// The line for what was loaded.
    pub loaded: &'a dyn Fn(&L) -> String,
    /// The line for a finished epoch.
    pub epoch: &'a dyn Fn(&E) -> String,
}

impl<L, E> TrainingDisplay<'_, L, E> {
    /// Runs `train` with this display fed from its events.
    pub fn run<R>(
        &self,
        train: impl FnOnce(&mut dyn FnMut(&learn::Progress<L, E>)) -> learn::Result<R>,
    ) -> learn::Result<R> {
        use learn::Progress;
        let mut pb: Option<ProgressBar> = None;
        let prefix = self.prefix;
        let result = train(&mut |event| match event {
            Progress::Loaded(l) => {
                if self.lines {
                    eprintln!("{}", (self.loaded)(l));
                }
            }
            Progress::Resumed { epoch } => eprintln!("{prefix}resuming after epoch {epoch}"),
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
                    eprintln!("{}", (self.epoch)(m));
                }
            }
            Progress::EarlyStop { epoch, best_epoch } => {
                if self.lines {
                    eprintln!("{prefix}early stop after epoch {epoch}; keeping epoch {best_epoch}");
                }
            }
        });
        if let Some(p) = pb {
            p.finish_and_clear();
        }
        result
    }
}
