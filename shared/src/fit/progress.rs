//! What an identification tells as it runs: the stage, the progress after every
//! iteration (the callback of [`crate::fit::identify::identify`]) and the convergence trace.

use crate::capacity::TRACE_CAPACITY;

/// Which stage is running.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Stage {
    /// FFO iterations.
    Search,
    /// Levenberg-Marquardt iterations.
    Refine,
    /// The profile check of the uncertainty ([`crate::fit::profile_check`]): its least-squares
    /// iterations, after the fit.
    Check,
}

/// Progress report, after every FFO or refinement iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Stage.
    pub stage: Stage,
    /// Iteration within the stage.
    pub iteration: u32,
    /// Iterations the stage will run at most.
    pub iterations: u32,
    /// Evaluations spent so far in total.
    pub evaluations: u32,
    /// Best fitness so far (RMSE of speed for speed-only records).
    pub best: f32,
}

/// One point of the convergence trace (paper's Fig. 10).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracePoint {
    /// Evaluations spent.
    pub evaluations: u32,
    /// Best fitness then.
    pub best: f32,
}

/// Add `point` to the trace; when it is full, the newest point takes the last slot.
pub(crate) fn push_trace(trace: &mut heapless::Vec<TracePoint, TRACE_CAPACITY>, point: TracePoint) {
    if trace.push(point).is_err() {
        // Full: keep the newest point in the last slot.
        if let Some(last) = trace.last_mut() {
            *last = point;
        }
    }
}
