//! Progress bar on stderr for long fits (hidden when stderr is not a terminal or with --quiet).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use motor_id_shared::fit::identify::{Progress, Stage};

/// A progress bar fed by the identification's progress callback.
pub struct FitProgress {
    bar: ProgressBar,
}

impl FitProgress {
    /// A bar; hidden when `quiet`.
    pub fn new(quiet: bool) -> FitProgress {
        let bar = ProgressBar::with_draw_target(
            Some(1),
            if quiet {
                ProgressDrawTarget::hidden()
            } else {
                ProgressDrawTarget::stderr()
            },
        );
        bar.set_style(
            ProgressStyle::with_template("{spinner} {prefix:>7} [{bar:30}] {pos}/{len} {msg}")
                .expect("static template")
                .progress_chars("=> "),
        );
        FitProgress { bar }
    }

    /// Report one iteration.
    pub fn update(&self, p: &Progress) {
        self.bar.set_prefix(match p.stage {
            Stage::Search => "FFO",
            Stage::Refine => "refine",
        });
        self.bar.set_length(p.iterations as u64);
        self.bar.set_position(p.iteration as u64);
        self.bar
            .set_message(format!("{} evaluations, best {:.5}", p.evaluations, p.best));
    }

    /// Remove the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
