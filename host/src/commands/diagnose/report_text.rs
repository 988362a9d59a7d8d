//! The text summary of the `diagnose` report ([`super::report`]), printed on stdout.

use super::coverage;
use super::remainder::{floor, UNEXPLAINED_RATIO};
use super::report::DiagnoseReport;

impl DiagnoseReport {
    /// The text summary printed on stdout.
    pub fn text(&self) -> String {
        let mut s = String::new();
        s += &format!(
            "baseline: train rmse {:.4}, holdout rmse {:.4} rad/s (holdout noise {:.4})\n",
            self.baseline.train_rmse.decimal(),
            self.baseline.holdout_rmse.decimal(),
            self.verdict.holdout_noise.decimal()
        );
        s += "where:\n";
        for line in &self.where_.summary {
            s += &format!("  {line}\n");
        }
        s += "effects, best held-out misfit first:\n";
        for e in &self.effects {
            s += &format!(
                "  {:<20} train {:.4}  holdout {:.4}{}\n",
                e.name,
                e.train_rmse.decimal(),
                e.holdout_rmse.decimal(),
                if e.significant { "  significant" } else { "" }
            );
            if let Some(r) = &e.restarted {
                s += &format!("  {:<20} {}\n", "", r.line());
            }
        }
        let v = &self.verdict;
        match (v.effect, &v.chosen) {
            (Some(name), Some(chosen)) => {
                let params = serde_json::to_string(&chosen.effect_params)
                    .expect("parameters always serialise");
                // The figures are the final model's: with every effect in it.
                let with = match (v.effects.len() > 1, v.partial.iter().any(|p| p.in_model)) {
                    (_, true) => " with the effects below and the partial stand-ins",
                    (true, false) => " with the effects below",
                    (false, false) => "",
                };
                s += &format!(
                    "verdict: {name}: holdout rmse {:.4} -> {:.4} rad/s{with} ({:.0} % of the misfit above noise removed), params {params}\n",
                    v.holdout_rmse_before.decimal(),
                    v.holdout_rmse_after.decimal(),
                    100.0 * v.share_of_misfit_removed.decimal(),
                );
                for then in v.effects.iter().skip(1) {
                    s += &format!(
                        "then: {}: holdout rmse -> {:.4} rad/s\n",
                        then.name,
                        then.holdout_rmse_after.decimal()
                    );
                    if let Some(r) = &then.restarted {
                        s += &format!("  {}\n", r.line());
                    }
                }
            }
            _ if !v.partial.is_empty() => {
                s += "verdict: no cause named (the effects found only stand in for part of the misfit)\n";
            }
            _ => s +=
                "verdict: null (no effect of the catalogue improves the held-out fit significantly)\n",
        }
        for p in &v.partial {
            s += &format!(
                "partial stand-in: {}: removes {:.0} % of the held-out {} misfit above the floor; not named: {}\n",
                p.name,
                100.0 * p.share_of_excess.decimal(),
                p.channel,
                p.why
            );
        }
        if let Some(w) = &v.widened {
            s += &format!("widened: {}\n", w.line());
        }
        match &v.remainder {
            Some(r) => {
                for line in &r.summary {
                    s += &format!("unexplained: {line}\n");
                }
            }
            None if v.unexplained => {
                let names: Vec<&str> = v
                    .partial
                    .iter()
                    .filter(|p| p.in_model)
                    .map(|p| p.name)
                    .collect();
                if !names.is_empty() {
                    s += &format!(
                        "unexplained: the held-out misfit ({:.4} rad/s) reaches the floor only with the partial stand-ins ({}): no named cause accounts for their share\n",
                        v.holdout_rmse_after.decimal(),
                        names.join(", ")
                    );
                }
                if let Some(c) = v.current.as_ref().filter(|c| c.unexplained) {
                    s += &format!(
                        "unexplained: the held-out current misfit ({:.4} A) stays above {UNEXPLAINED_RATIO} x its noise ({:.4} A)\n",
                        c.holdout_rmse_after.decimal(),
                        c.holdout_noise.decimal()
                    );
                    for line in &c.where_ {
                        s += &format!("unexplained: {line}\n");
                    }
                }
            }
            None => {
                let (floor_rmse, kind) = floor(
                    v.holdout_noise.0,
                    v.repeatability_floor.as_ref().map(|f| f.0),
                );
                s += &format!(
                    "explained: the held-out misfit ({:.4} rad/s) is within {UNEXPLAINED_RATIO} x the {kind} floor ({floor_rmse:.4} rad/s)\n",
                    v.holdout_rmse_after.decimal()
                );
            }
        }
        if let Some(c) = &v.current {
            s += &format!(
                "current: holdout rmse {:.4} -> {:.4} A (noise {:.4} A){}\n",
                c.holdout_rmse_before.decimal(),
                c.holdout_rmse_after.decimal(),
                c.holdout_noise.decimal(),
                if c.unexplained {
                    ": significantly above its noise, not explained by the catalogue"
                } else {
                    ""
                }
            );
        }
        for line in self.repeatability.summary() {
            s += &format!("{line}\n");
        }
        for line in coverage::summary(&self.coverage_gaps) {
            s += &format!("coverage: {line}\n");
        }
        for c in &self.cannot_support {
            s += &format!("note: {c}\n");
        }

        s
    }
}
