//! Progress bar on stderr for long fits (hidden when stderr is not a terminal or with --quiet).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use motor_id_shared::fit::identify::{Progress, Stage};

/// What the bar shows at one moment: its label, how far along its stage is, and a message.
#[derive(Clone, Debug, PartialEq)]
pub struct BarState {
    /// The stage's label (`FFO`, `refine`, `check`, `experiment`).
    pub prefix: &'static str,
    /// Steps done in the stage.
    pub position: u64,
    /// Steps the stage runs at most: the bar's length, fixed for the stage (a position past it
    /// stretches it, so the bar never runs backwards).
    pub length: u64,
    /// What else to say (evaluations, best fitness).
    pub message: String,
}

impl BarState {
    /// The bar after one iteration of an identification.
    pub fn of(p: &Progress) -> BarState {
        BarState {
            prefix: match p.stage {
                Stage::Search => "FFO",
                Stage::Refine => "refine",
                Stage::Check => "check",
            },
            position: u64::from(p.iteration),
            length: u64::from(p.iterations.max(p.iteration).max(1)),
            message: format!("{} evaluations, best {:.5}", p.evaluations, p.best),
        }
    }
}

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
            ProgressStyle::with_template("{spinner} {prefix:>10} [{bar:30}] {pos}/{len} {msg}")
                .expect("static template")
                .progress_chars("=> "),
        );
        FitProgress { bar }
    }

    /// Report one iteration.
    pub fn update(&self, p: &Progress) {
        self.show(&BarState::of(p));
    }

    /// Show `s`.
    pub fn show(&self, s: &BarState) {
        self.bar.set_prefix(s.prefix);
        self.bar.set_length(s.length);
        self.bar.set_position(s.position);
        self.bar.set_message(s.message.clone());
    }

    /// Remove the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
